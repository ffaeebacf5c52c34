"""The layer under evaluation, online fine-tuning, expert demos and videos: one episode rollout and its sharding."""
