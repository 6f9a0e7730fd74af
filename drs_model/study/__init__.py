"""Tolerance studies: many parameter samples through the model, on Dask (``drs study``).

* :mod:`.spec`: the TOML specification (distributions per DRSParams field, sampler, scene);
* :mod:`.design`: the samples (scipy.stats.qmc; the pick-freeze design of Sobol' indices);
* :mod:`.evaluate`: what each sample gives, for a batch at once (forces, margin, gaps);
* :mod:`.crossing`: opening and closing times, many samples in one compiled call;
* :mod:`.sensitivity`: Sobol' indices (scipy.stats.sobol_indices);
* :mod:`.run`: the chunks on Dask, the table (Parquet), the figures, the summary;
* :mod:`.plots`: histograms and the sensitivity ranking.

docs/study.md describes the whole.
"""

from .evaluate import RESULT_COLUMNS, TEXT_COLUMNS, evaluate
from .run import StudyResult, run_study, summary, write_outputs
from .spec import Normal, Scene, StudySpec, Uniform, parse_spec, read_spec

__all__ = [
    "RESULT_COLUMNS",
    "TEXT_COLUMNS",
    "Normal",
    "Scene",
    "StudyResult",
    "StudySpec",
    "Uniform",
    "evaluate",
    "parse_spec",
    "read_spec",
    "run_study",
    "summary",
    "write_outputs",
]
