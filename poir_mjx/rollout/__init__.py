"""The layer under evaluation, online fine-tuning, expert demos and videos: one episode rollout, the evaluator
(episode keys and the compiled rollout over a batch of them) and its sharding."""
