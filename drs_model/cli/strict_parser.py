"""The parser of every drs command line (:class:`StrictParser`): ``argparse`` with whole option
names only.

``argparse`` takes an unambiguous prefix of a long option by default (``--strok`` for
``--stroke``): a typo then runs something the user did not ask for, without a word. Sub-commands
made by ``add_subparsers().add_parser`` are of their parent's class, so one parser at the top of
each console script covers its verbs.
"""

from __future__ import annotations

import argparse


class StrictParser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` with ``allow_abbrev=False`` unless asked otherwise."""

    def __init__(self, *args, allow_abbrev: bool = False, **kwargs) -> None:
        super().__init__(*args, allow_abbrev=allow_abbrev, **kwargs)
