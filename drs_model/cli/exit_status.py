"""The exit statuses of every drs command line (``drs``, ``drs-bag`` and its verbs,
``drs-check``, ``drs-node``, ``drs-demo``): the one table of docs/cli.md, here as constants that
every tool takes.

Exit status 2 follows argparse and grep: "the input could not be used". Its kinds share the
number and are told apart by the one line on stderr: a bad option (``PROG: error: argument
OPTION: ...``, argparse's own line, before anything is read), a bag that cannot be read
(``PROG: error: 'BAG': ...``), an input the model refuses (``drs``: ``drs CMD: error: ...``) or a
node that refuses to start (``drs-node: refused to start: ...``, naming the parameter).
"""

from __future__ import annotations

#: Done, and every verdict passed (a bag verified within tolerance, a re-run within tolerance,
#: a play to its end, a node stopped by SIGINT/SIGTERM with both recordings finished).
EXIT_OK = 0
#: The verdict is negative: a check failed, a re-run deviates, a bag of a fleet did not pass,
#: a check of the demo failed.
EXIT_FAILED = 1
#: An option the tool cannot use (argparse's usage error; it names the option).
EXIT_USAGE = 2
#: A bag that is missing, unreadable, corrupt or inconsistent, or that lacks what the verb needs.
EXIT_UNREADABLE = 2
#: The model refuses an input (``drs``), or the node refuses to start (a parameter or a
#: recording path; the line names it).
EXIT_REFUSED = 2
#: A damaged bag whose readable part was used (``check --recover``, ``recover``).
EXIT_RECOVERED = 3
#: The tool's own failure, no verdict on the input: a message that passed every check of the
#: file made the checker fail, or the node stopped on an error of its own while running.
EXIT_INTERNAL = 4
#: ``drs-bag resimulate``: the bag, which reads, holds no run to re-run (it names no drs node,
#: as another tool's bag, or its node took no command and never stepped): no verdict to give.
EXIT_NOTHING_TO_RERUN = 5
#: ``drs-bag fit``: its two stages (equation error, output error) disagree on a parameter by
#: more than their intervals allow: neither interval can be bet on (the report names them).
EXIT_INCONSISTENT = 6

__all__ = [
    "EXIT_FAILED",
    "EXIT_INCONSISTENT",
    "EXIT_INTERNAL",
    "EXIT_NOTHING_TO_RERUN",
    "EXIT_OK",
    "EXIT_RECOVERED",
    "EXIT_REFUSED",
    "EXIT_UNREADABLE",
    "EXIT_USAGE",
]
