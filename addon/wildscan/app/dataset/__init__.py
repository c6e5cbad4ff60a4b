"""`wildscan dataset`: many worlds x many poses, resumable, on Dask, in the formats training
code reads (docs/datasets.md)."""

from .run import Interrupted, RunReport, VerifyReport, run_dataset, verify_dataset
from .spec import DatasetSpec, load_spec, spec_from_dict

__all__ = [
    "DatasetSpec",
    "Interrupted",
    "RunReport",
    "VerifyReport",
    "load_spec",
    "run_dataset",
    "spec_from_dict",
    "verify_dataset",
]
