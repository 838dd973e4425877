"""Entry point of the ``ismpc`` command line: parse, dispatch to a command, map errors to exit status.

Exit status: 0 success (also when the robot fell: the outcome is in ``summary.json``),
2 bad input (one line on stderr), 1 an unexpected internal error, 3 ``ismpc robot check`` ran
and the robot failed it, 130 interrupted.
"""

from __future__ import annotations

import logging
import sys

from ..exceptions import IsmpcError
from .args import build_parser, flag_names
from .common import _interrupted
from .experiment_commands import cmd_bench, cmd_calibrate, cmd_soak, cmd_sweep
from .robot_commands import cmd_robot
from .run_commands import cmd_compare, cmd_run, cmd_scenarios

#: Commands whose Ctrl-C (and SIGTERM) ends the simulation at a tick boundary and writes what
#: ran; the others stop at once (a sweep keeps its finished trials in runs.csv).
DEFERRED_INTERRUPT_COMMANDS = ("run", "compare", "soak")


def main(argv: list[str] | None = None) -> int:
    from ..runs.outputs import Interrupts

    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING if args.verbose else logging.ERROR, format="%(levelname)s %(message)s")
    if args.command is None:
        parser.print_help()
        return 2
    handlers = {"run": cmd_run, "compare": cmd_compare, "bench": cmd_bench, "sweep": cmd_sweep, "soak": cmd_soak,
                "scenarios": cmd_scenarios, "calibrate": cmd_calibrate, "robot": cmd_robot}
    args.out_dir = None
    if getattr(args, "robot", None) is not None:
        from ..robots import robot_reference

        args.robot = robot_reference(args.robot)
    args.interrupts = Interrupts(deferred=args.command in DEFERRED_INTERRUPT_COMMANDS).install()
    logging.captureWarnings(True)  # numerical warnings go to the log (shown with --verbose), not stderr
    try:
        return handlers[args.command](args)
    except IsmpcError as exc:
        if args.interrupts.requested:
            return _interrupted(args, "stopped before a run finished; nothing more was written")
        sys.stderr.write(f"ismpc: error: {flag_names(str(exc))}\n")
        return 2
    except BrokenPipeError:  # the reader of stdout is gone (`ismpc scenarios | head -1`): nothing to say
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit
        return 0
    except KeyboardInterrupt:
        if args.interrupts.deferred:
            return _interrupted(args, "stopped at once (second signal); files already written were kept")
        return _interrupted(args, "files already written were kept")
    except Exception as exc:  # an internal error: one line, details only with --verbose
        logging.getLogger("robust_ismpc").debug("internal error", exc_info=True)
        sys.stderr.write(f"ismpc: internal error: {type(exc).__name__}: {exc} (rerun with --verbose for details)\n")
        if args.verbose:
            raise
        return 1
    finally:
        logging.captureWarnings(False)
        args.interrupts.restore()
        if args.out_dir is not None:
            args.out_dir.release()
