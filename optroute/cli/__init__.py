"""The ``optroute`` command line.

One subcommand per task, each a ``cmd_<name>(args) -> int`` function registered by
``add_<name>(subparsers, common)``:

==========  ===========================================================  ======================
command     what it does                                                 module
==========  ===========================================================  ======================
plan        endpoints → route search → corridor NLP → plan files         :mod:`.voyage`
optimise    a corridor from GeoJSON/CSV → corridor NLP → plan files      :mod:`.voyage`
tradeoff    the fuel-versus-ETA front → NetCDF, CSV, PNG                 :mod:`.studies`
study       ships × weather × ETAs on Dask, resumable                    :mod:`.studies`
bands       forbidden speeds of one heading in one sea state             :mod:`.bands`
demo        San Diego → Tokyo through two storms (Boeing EP 2145155)     :mod:`.tools`
bench       the benchmarks of a source checkout                          :mod:`.tools`
==========  ===========================================================  ======================

``optroute --version`` prints ``optroute 0.2.0`` (:mod:`optroute._version`).  Building the
parser imports nothing heavy (:mod:`optroute.cli._parser`): ``--help`` answers at once, and a
command imports numpy, xarray, CasADi... when it runs.  Times print as ISO 8601 UTC to the
second (:func:`optroute.units.format_utc`); every status printed is explained
(:mod:`optroute.cli._status`); an error's fix names the command line's options
(:mod:`optroute.cli._voice`).

Exit codes
----------
0 success; 2 bad input (a usage error, or any :class:`~optroute.errors.OptrouteError`
about the input: unknown preset or scenario, a bad ship file, an ETA before the
departure, a corridor on land, weather not covering the voyage, ...); 3 infeasible
(:class:`~optroute.errors.InfeasibleETA`, :class:`~optroute.errors.NoSafePassage`); 4 a
solver failure (:class:`~optroute.errors.SolverFailure`); 130 interrupted (Ctrl-C).
Errors are one ``optroute: error: ...`` line on stderr, the traceback too with
``--debug``; warnings one ``optroute: warning: ...`` line each.  Anything else escaping
is a bug and keeps Python's traceback and code 1.
"""

from __future__ import annotations

import argparse
import re
import sys
import warnings
from collections.abc import Sequence

from optroute.cli._parser import PROG, Parser, UsageError, add_version_option
from optroute.cli._voice import cli_voice
from optroute.cli.bands import add_bands, cmd_bands
from optroute.cli.observe import add_observe
from optroute.cli.simulate import add_simulate
from optroute.cli.studies import add_study, add_tradeoff, cmd_study, cmd_tradeoff
from optroute.cli.tools import add_bench, add_demo, cmd_bench, cmd_demo
from optroute.cli.voyage import add_optimise, add_plan, cmd_optimise, cmd_plan
from optroute.errors import InfeasibleETA, NoSafePassage, OptrouteError, SolverFailure

EXIT_OK = 0
EXIT_BAD_INPUT = 2
EXIT_INFEASIBLE = 3
EXIT_SOLVER_FAILURE = 4
EXIT_INTERRUPTED = 130

__all__ = [
    "EXIT_BAD_INPUT",
    "EXIT_INFEASIBLE",
    "EXIT_OK",
    "EXIT_SOLVER_FAILURE",
    "UsageError",
    "build_parser",
    "cmd_bands",
    "cmd_bench",
    "cmd_demo",
    "cmd_optimise",
    "cmd_plan",
    "cmd_study",
    "cmd_tradeoff",
    "exit_code",
    "main",
]

#: Options whose value may start with a minus sign (a southern or western position).
_SIGNED_VALUE_OPTIONS = ("--from", "--to")
_SIGNED = re.compile(r"^-\d|^-\.\d")


def build_parser() -> argparse.ArgumentParser:
    """The full ``optroute`` argument parser with every subcommand."""
    common = Parser(add_help=False)
    common.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help="show the traceback on errors")
    parser = Parser(
        prog=PROG,
        description="Ship voyage optimisation through forecast weather. 'optroute COMMAND --help' for each command.",
        epilog="exit codes: 0 success, 2 bad input, 3 infeasible (ETA or passage), 4 solver failure",
    )
    parser.add_argument("--debug", action="store_true", default=False, help="show the traceback on errors")
    add_version_option(parser)
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND", parser_class=Parser)
    add_demo(sub, common)
    add_plan(sub, common)
    add_optimise(sub, common)
    add_tradeoff(sub, common)
    add_study(sub, common)
    add_bands(sub, common)
    add_bench(sub, common)
    add_observe(sub, common)
    add_simulate(sub, common)
    return parser


def exit_code(exc: BaseException) -> int:
    """The exit code of an error: 3 infeasible, 4 solver failure, 2 any other input or usage error."""
    if isinstance(exc, InfeasibleETA | NoSafePassage):
        return EXIT_INFEASIBLE
    if isinstance(exc, SolverFailure):
        return EXIT_SOLVER_FAILURE
    return EXIT_BAD_INPUT


def _join_signed_values(argv: list[str]) -> list[str]:
    """``["--from", "-33.9,151.2"]`` → ``["--from=-33.9,151.2"]`` (argparse would take the value for an option)."""
    out: list[str] = []
    i = 0
    while i < len(argv):
        if argv[i] in _SIGNED_VALUE_OPTIONS and i + 1 < len(argv) and _SIGNED.match(argv[i + 1]):
            out.append(f"{argv[i]}={argv[i + 1]}")
            i += 2
            continue
        out.append(argv[i])
        i += 1
    return out


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``optroute`` script and ``python -m optroute``.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name; ``sys.argv[1:]`` by default.

    Returns
    -------
    int
        0 success, 2 bad input, 3 infeasible, 4 solver failure, 130 interrupted.
    """
    argv = _join_signed_values(list(sys.argv[1:] if argv is None else argv))
    debug = "--debug" in argv

    def show_warning(message, category, filename, lineno, file=None, line=None):  # noqa: ANN001, ANN202
        print(f"{PROG}: warning: {_one_line(str(message))}", file=sys.stderr)

    with warnings.catch_warnings():
        warnings.showwarning = show_warning
        try:
            args = build_parser().parse_args(argv)
            return int(args.func(args))
        except SystemExit as exc:  # --help
            return exc.code if isinstance(exc.code, int) else 0
        except (UsageError, OptrouteError) as exc:
            if debug:
                import traceback

                traceback.print_exc(file=sys.stderr)
            print(f"{PROG}: error: {_one_line(cli_voice(str(exc)))}", file=sys.stderr)
            return exit_code(exc)
        except KeyboardInterrupt:
            if debug:
                import traceback

                traceback.print_exc(file=sys.stderr)
            print(
                f"{PROG}: interrupted; files already written are complete, a study resumes when run again",
                file=sys.stderr,
            )
            return EXIT_INTERRUPTED
