"""Planner forensics (``python -m poir_mjx.cli diagnose``): why the imitation rewards' ranking wins or loses.

For the states a sweep cell's episodes visit (re-simulated in robosuite with the cell's keys), every planner call is
taken apart: which heads the top-k come from, each dimension's share of the L2 / DRIL / MOREL rewards, how far the
planned action is from EBC's, the world model's one-step error per observation group, and an oracle check: the same
candidate action sequences rolled out in the true simulator (robosuite, its state restored), with the rank
correlation between the model's returns and the true ones and the overlap of the two top-k sets.
"""
