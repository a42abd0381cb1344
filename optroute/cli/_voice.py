"""Library advice in the command line's words: each fix names an option the user of ``optroute`` has.

optroute's errors name the fix in the terms of the Python API that raised them
(``scheduler_address=None``, ``max_leg_nm``, ``time_policy='hold'``...).  The command line
prints them through :func:`cli_voice`, which puts each such phrase in the options of the
``optroute`` commands, or drops a clause whose option the command line does not offer.  Every
phrase below occurs verbatim in optroute's sources (``tests/test_cli.py`` checks it, so that a
reworded message cannot slip past this table).
"""

from __future__ import annotations

#: (the library's phrase, what the command line says instead); applied in order.
CLI_FIXES: tuple[tuple[str, str], ...] = (
    # studies.study.SchedulerUnreachable: the study command's --scheduler / --workers
    ("or pass scheduler_address=None for a local cluster", "or leave out --scheduler for a local cluster"),
    ("('synchronous' runs in this process)", "(--workers 0 runs in this process)"),
    (" or raise timeout_s", ""),  # the command line waits the library's default
    # weather.sample / optimise.corridor_problem: the command line opens weather with time_policy="raise"
    (", or pass time_policy='hold' to hold the first/last time slice", ""),
    (", or open the weather with time_policy='hold'", ""),
    # optimise.lateral
    ("shorter legs (max_leg_nm)", "shorter legs (--max-leg-nm)"),
    ("plan it with plan_voyage", "plan it with 'optroute plan'"),
    # studies.tradeoff
    ("pass etas= to draw the front without it", "give --etas to draw the front without it"),
    ("or pass solver_options", "or raise --max-iter"),
    # optimise.rescue
    ("extend the forecast or pass an ETA", "extend the forecast or give --eta"),
    # physics.speed_loss: no option of the command line marks unreachable cases
    (", or pass on_unreachable='nan' to mark such cases", ""),
    (", or pass on_unreachable='nan'", ""),
)


def cli_voice(message: str) -> str:
    """``message`` with every library phrase of :data:`CLI_FIXES` in the command line's words."""
    for library, cli in CLI_FIXES:
        message = message.replace(library, cli)
    return message


__all__ = ["CLI_FIXES", "cli_voice"]
