"""`wildscan dataset`: many worlds x many poses, resumable, on Dask, in the formats training
code reads (docs/datasets.md)."""

from .cluster import RunFailed
from .run import Interrupted, RunReport, run_dataset
from .spec import DatasetSpec, load_spec, spec_from_dict
from .verify import VerifyReport, verify_dataset

__all__ = [
    "DatasetSpec",
    "Interrupted",
    "RunFailed",
    "RunReport",
    "VerifyReport",
    "load_spec",
    "run_dataset",
    "spec_from_dict",
    "verify_dataset",
]
