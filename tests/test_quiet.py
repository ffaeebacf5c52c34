"""Known, harmless import-time messages are silenced; everything else still shows (poir_mjx/quiet.py)."""

import subprocess
import sys

from poir_mjx.optional import has_robosuite


def test_known_import_messages_are_silenced_and_others_pass():
    rs = "import robosuite; " if has_robosuite() else ""
    code = ("import logging, poir_mjx, mujoco.mjx; " + rs +
            "logging.getLogger('robosuite_logs').warning('another robosuite warning'); print('done')")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    text = out.stdout + out.stderr
    assert out.returncode == 0 and "done" in out.stdout, text
    for known in ("Failed to import warp", "Failed to import mujoco_warp", "No private macro file",
                  "robosuite_models", "mink-based"):  # fmt: skip
        assert known not in text, text
    assert "another robosuite warning" in text
