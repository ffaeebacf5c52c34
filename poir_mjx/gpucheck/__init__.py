"""``make gpu-check`` (``python -m poir_mjx.cli gpu-check``): the prepared, offline GPU run.

A lent GPU gives 15 minutes of device time in all, machine start included, so its run is one prepared
command: five stages in priority order (``stages.py``), each under a deadline (``runner.py``) so the
whole stays within ``budget_s``, each writing its JSON file under ``--out`` after every row, a rerun
skipping the stages already complete. ``--dry-run`` runs the same stages at tiny sizes on the CPU
(``sizes.DRY``), in-process; ``make test-current`` runs it, so the script cannot rot.
"""
