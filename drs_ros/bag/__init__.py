"""The ``drs-bag`` tools (named after ``ros2 bag``), one sub-package per job.

At the top: :mod:`.cli` (the verbs), :mod:`.verb` (the skeleton of ``check``, ``resimulate``
and ``fit``), ``info``, ``recover``, ``merge``, :mod:`.new_bag` (what they write) and ``from_goal``;
:mod:`.read` (a bag's files, every byte verified, the records decoded, the drs nodes it holds),
:mod:`.check` (``drs-bag check``), :mod:`.replay` (``resimulate`` and ``play``) and
:mod:`.season` (many bags: the fleet, ``index``, ``fit``, ``trend``).
"""
