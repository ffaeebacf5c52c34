"""poir-mjx command line: ``python -m poir_mjx.cli <command> [<subcommand>] [--flags]`` (or ``poir-mjx``).

    sweep --config experiments/cpu-small.json [--planner.sigma 0.1 ...]   success rate versus noise (make sweep)
    eval --ckpt PATH [--sigma-init ...] [--simulator both]               evaluate one checkpoint (make eval, xsim)
    compare RUN... [--out F]                                             one table across runs (make ablations)
    report [--results results] [--check]                                 results/README.md from the runs (make report)
    video --run RUN --method M [--versus M2] --sigma-init S              a cell's episodes as an MP4 (make video)
    diagnose --run RUN [--method POIR-L2] [--sigma-init 0.02 0.3]       planner forensics with the oracle (make diagnose)
    envs / demos generate|success|spread|compact / bench env|physics|planner|e2e|robosuite|l2   the other make targets

Each subcommand is a frozen dataclass of its options (``poir_mjx/options.py``, or the module that
owns it) and a function taking it; tyro builds the parser from the dataclasses (``--help`` on any
subcommand lists its flags). Bad input: one line on stderr naming the file or the flag, exit status 2.
"""

from __future__ import annotations

import errno
import sys

from poir_mjx import options as o
from poir_mjx.cli.parser import Command, parse
from poir_mjx.versions import set_command_line

# The registry: adding a subcommand is one line here. The options class and the function may be given as
# "module:name" strings, imported when the parser is built (the class) or when the subcommand runs (the
# function), e.g. Command("video", "poir_mjx.video:VideoConfig", "poir_mjx.video:render_video").
COMMANDS: tuple[Command, ...] = (
    Command("sweep", o.Sweep, "poir_mjx.cli.run:sweep"),
    Command("eval", o.Eval, "poir_mjx.cli.evaluate:evaluate"),
    Command("compare", o.Compare, "poir_mjx.cli.run:compare"),
    Command("report", o.Report, "poir_mjx.cli.run:report"),
    Command("envs", o.Envs, "poir_mjx.cli.run:envs"),
    Command("demos generate", o.DemosGenerate, "poir_mjx.cli.demos:run_generate"),
    Command("demos success", o.DemosSuccess, "poir_mjx.cli.demos:run_success"),
    Command("demos spread", o.DemosSpread, "poir_mjx.cli.demos:run_spread"),
    Command("demos compact", o.DemosCompact, "poir_mjx.cli.demos:run_compact"),
    Command("bench env", "poir_mjx.bench.options:BenchEnv", "poir_mjx.bench.env:run"),
    Command("bench physics", "poir_mjx.bench.options:BenchPhysics", "poir_mjx.bench.physics:run"),
    Command("bench planner", "poir_mjx.bench.options:BenchPlanner", "poir_mjx.bench.planner:run"),
    Command("bench e2e", "poir_mjx.bench.options:BenchE2E", "poir_mjx.bench.e2e:run"),
    Command("bench robosuite", "poir_mjx.bench.options:BenchRobosuite", "poir_mjx.bench.robosuite:run"),
    Command("bench precision", "poir_mjx.bench.options:BenchPrecision", "poir_mjx.bench.precision:run",
            "poir_mjx.bench.precision:require_robosuite"),
    Command("bench l2", "poir_mjx.bench.options:BenchL2", "poir_mjx.bench.l2:run", "poir_mjx.bench.l2:require_robosuite"),
    Command("gpu-check", o.GpuCheck, "poir_mjx.gpucheck.command:run"),
    Command("video", "poir_mjx.video:VideoConfig", "poir_mjx.video.command:run", "poir_mjx.video.render:check_gl"),
    Command("diagnose", "poir_mjx.diagnose.config:DiagnoseConfig", "poir_mjx.diagnose.run:run",
            "poir_mjx.diagnose.config:require_robosuite"),
)
# Subcommand groups: (help line, the subcommand run when none is named or None).
GROUPS = {
    "demos": ("Scripted-expert demonstrations (make demos), the expert's success rate, demo sets' action spread.", "generate"),
    "bench": ("Throughput benchmarks (make bench-env: env and physics; bench-planner, bench-e2e, bench-robosuite).", None),
}
PROG = "poir-mjx"
# OSErrors reported as one line (exit status 2) rather than a traceback: no space, no quota, read-only, forbidden.
ENVIRONMENT_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM}


def check_flags(opts) -> None:
    """The options' values checked as every typed config is (``typed_config.check``: types, signs, bounds), each
    error naming the flag."""
    from poir_mjx.typed_config import ConfigError, check

    try:
        check(opts)
    except ConfigError as e:
        field, _, problem = str(e).partition(": ")
        raise ConfigError(f"--{field.replace('_', '-')}: {problem}") from None


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    set_command_line(argv)
    parsed = parse(COMMANDS, GROUPS, argv, PROG)
    if isinstance(parsed, str):  # a parse error, as one line
        print(f"error: {parsed}", file=sys.stderr)
        return 2
    command, opts = parsed
    check = command.check_function()
    if check is not None:
        from poir_mjx.optional import MissingDependencyError

        try:
            check()
        except MissingDependencyError as e:
            print(f"error: {e}", file=sys.stderr)
            return 2

    from poir_mjx.core.agent import TrainingDivergedError
    from poir_mjx.core.checkpoint import CheckpointError
    from poir_mjx.core.config import ConfigError
    from poir_mjx.data.robomimic import DatasetError
    from poir_mjx.devices import DeviceError
    from poir_mjx.envs.env import ModelFileError
    from poir_mjx.envs.tasks import UnknownTaskError
    from poir_mjx.eval.methods import UnknownMethodError
    from poir_mjx.optional import MissingDependencyError

    try:
        from poir_mjx.outputs import check_options

        check_flags(opts)  # every value in its bounds (the one validation of typed configs), before any work
        check_options(opts)  # every path the command writes, before any work
        if command.name not in ("compare", "report", "envs"):  # every command that computes: full float32 on a GPU
            from poir_mjx.devices import pin_precision

            pin_precision()
        rc = command.function()(opts)
    except (ConfigError, CheckpointError, DatasetError, ModelFileError, UnknownTaskError, UnknownMethodError,
            MissingDependencyError, DeviceError, TrainingDivergedError) as e:  # fmt: skip
        print(f"error: {e}", file=sys.stderr)
        return 2
    except OSError as e:  # the machine's, not the input's: a full disk, a read-only or forbidden folder
        if e.errno not in ENVIRONMENT_ERRNOS:
            raise
        print(f"error: {e.filename or 'a write'}: {e.strerror} (files are written atomically: none was left "
              "half-written)", file=sys.stderr)  # fmt: skip
        return 2
    return rc if type(rc) is int else 0
