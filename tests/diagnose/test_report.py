"""The forensics page's own lines (diagnose/report.py)."""

from poir_mjx.diagnose.report import provenance_line


def test_the_page_names_every_command_that_wrote_its_records():
    """Cells diagnosed by two commands (e.g. sigma_init 0.02 one day, 0.3 the next) name both, and each field's
    value once where the records agree."""

    def prov(cmd):
        return {"simulator": "robosuite 1.5.2", "machine": "AMD EPYC, 2 cores", "command": cmd,
                "demos": {"source": "scripted expert", "sha256": "a0fd"}}

    line = provenance_line({"a": {"provenance": [prov("diagnose --sigma-init 0.02")] * 2},
                            "b": {"provenance": [prov("diagnose --sigma-init 0.3")]}})
    assert line == ("Simulator: robosuite 1.5.2; machine: AMD EPYC, 2 cores; demos: scripted expert (sha256 a0fd); "
                    "commands: `diagnose --sigma-init 0.02`; `diagnose --sigma-init 0.3`.")
    assert provenance_line({"a": {"provenance": []}}) == ""
