# The subpackage's public names (lazy_loader.attach_stub reads this file; type
# checkers read it as the package's stub). One list: add a name here only.

from ._identify import (
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
from ._records import (
    COLUMNS,
    append_records,
    done_trial_ids,
    read_records,
)
from ._run import (
    run_directory,
    run_experiment,
    run_metadata,
)
from ._stats import (
    PAPER_TABLE1,
    AxisError,
    ErrorTable,
    error_table,
    error_tables,
    garment_summary_markdown,
    table1_markdown,
)
from ._study import (
    write_experiment_report,
)
from ._trials import (
    ExperimentConfig,
    Trial,
    plan_trials,
    run_trial,
    trial_inputs,
    trial_locator,
    trial_record,
)

__all__ = [
    "AxisError",
    "COLUMNS",
    "ErrorTable",
    "ExperimentConfig",
    "IDENTIFY_COLUMNS",
    "IdentifyExperimentConfig",
    "IdentifyTrial",
    "PAPER_TABLE1",
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
    "run_directory",
    "run_experiment",
    "run_identify_experiment",
    "run_identify_trial",
    "run_metadata",
    "run_trial",
    "summarise_identify",
    "table1_markdown",
    "trial_inputs",
    "trial_locator",
    "trial_record",
    "write_experiment_report",
    "write_identify_report",
]
