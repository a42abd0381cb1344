"""The ``optroute`` parser's building blocks: standard library only.

``optroute --help`` and ``optroute COMMAND --help`` build the whole parser, so everything
imported while it is built — this module, :mod:`optroute.errors` and the ``add_<name>``
functions of the command modules — stays clear of numpy, xarray, CasADi, CVXPY, matplotlib,
Dask and numba; the ``cmd_<name>`` functions import those when a command runs
(``tests/test_cli.py`` checks it in a fresh interpreter).
"""

from __future__ import annotations

import argparse
import textwrap
from typing import NoReturn

PROG = "optroute"


class UsageError(Exception):
    """A command-line usage error (argparse's), reported as exit code 2."""


class Parser(argparse.ArgumentParser):
    """ArgumentParser that raises instead of printing the usage and exiting."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{message} (see '{self.prog} --help')")


def add_command(
    sub: argparse._SubParsersAction,
    common: argparse.ArgumentParser,
    name: str,
    *,
    help: str,
    description: str,
    examples: str,
) -> argparse.ArgumentParser:
    """A subcommand parser whose ``--help`` shows defaults and an *examples* epilog."""
    return sub.add_parser(
        name,
        parents=[common],
        help=help,
        description=textwrap.fill(description, 88),
        epilog="examples:\n" + examples.strip("\n"),
        formatter_class=_HelpFormatter,
    )


class _HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Keeps the examples' line breaks; shows an option's default unless it is None/False or the help names one."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        default = action.default
        if "default" in text or default is None or default is False or default is argparse.SUPPRESS:
            return text
        if action.option_strings or action.nargs in (argparse.OPTIONAL, argparse.ZERO_OR_MORE):
            return text + " (default: %(default)s)"
        return text


def add_progress_option(p: argparse.ArgumentParser) -> None:
    """`--progress`/`--no-progress` (default: when stderr is a terminal)."""
    p.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="show a progress bar on stderr (default: when stderr is a terminal)",
    )


def add_version_option(parser: argparse.ArgumentParser) -> None:
    """``--version``: ``optroute 0.2.0`` (:mod:`optroute._version`) on stdout, exit 0."""
    from optroute._version import __version__

    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
