"""The accuracy experiment: many recognitions on simulated (or recorded) scenes, their records,
the paper's statistics (Table 1) and figures, run locally or on a Dask cluster, resumable.

The figures (``photomodel.experiments._report``, matplotlib) load only when a report is written.
"""

from photomodel.experiments._identify import (
    IDENTIFY_COLUMNS,
    IdentifyExperimentConfig,
    IdentifyTrial,
    calibrate_from_records,
    plan_identify_trials,
    read_identify_records,
    run_identify_experiment,
    run_identify_trial,
    summarise_identify,
    write_identify_report,
)
from photomodel.experiments._records import (
    COLUMNS,
    append_records,
    done_trial_ids,
    read_records,
)
from photomodel.experiments._run import run_experiment, run_metadata
from photomodel.experiments._stats import (
    PAPER_TABLE1,
    AxisError,
    ErrorTable,
    error_table,
    error_tables,
    garment_summary_markdown,
    table1_markdown,
)
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
    "IDENTIFY_COLUMNS",
    "PAPER_TABLE1",
    "AxisError",
    "ErrorTable",
    "ExperimentConfig",
    "IdentifyExperimentConfig",
    "IdentifyTrial",
    "Trial",
    "append_records",
    "calibrate_from_records",
    "done_trial_ids",
    "error_table",
    "error_tables",
    "garment_summary_markdown",
    "plan_identify_trials",
    "plan_trials",
    "read_identify_records",
    "read_records",
    "run_experiment",
    "run_identify_experiment",
    "run_identify_trial",
    "run_metadata",
    "run_trial",
    "summarise_identify",
    "table1_markdown",
    "trial_inputs",
    "trial_record",
    "write_identify_report",
    "write_experiment_report",
]
