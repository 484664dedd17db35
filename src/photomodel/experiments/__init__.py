"""The accuracy experiment: many recognitions on simulated (or recorded) scenes, their records,
the paper's statistics (Table 1) and figures, run locally or on a Dask cluster, resumable."""

from photomodel.experiments._records import (
    COLUMNS,
    append_records,
    done_trial_ids,
    read_records,
)
from photomodel.experiments._run import run_experiment, run_metadata
from photomodel.experiments._study import write_experiment_report
from photomodel.experiments._trials import (
    ExperimentConfig,
    Trial,
    plan_trials,
    run_trial,
    trial_inputs,
    trial_record,
)

__all__ = [
    "COLUMNS",
    "ExperimentConfig",
    "Trial",
    "append_records",
    "done_trial_ids",
    "plan_trials",
    "read_records",
    "run_experiment",
    "run_metadata",
    "run_trial",
    "trial_inputs",
    "trial_record",
    "write_experiment_report",
]
