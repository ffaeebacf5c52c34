"""Evaluation: the methods (registry), their episodes in MJX or robosuite (a worker pool), the scripted expert's
success rate, and the statistics of success counts."""
