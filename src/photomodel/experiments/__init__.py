"""The accuracy experiment: many recognitions on simulated (or recorded) scenes, their records,
the paper's statistics (Table 1) and figures, run locally or on a Dask cluster, resumable.

The figures (``photomodel.experiments._report``, matplotlib) load only when a report is written.
"""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_identify": [
            "IDENTIFY_COLUMNS",
            "IdentifyExperimentConfig",
            "IdentifyTrial",
            "calibrate_from_records",
            "plan_identify_trials",
            "read_identify_records",
            "run_identify_experiment",
            "run_identify_trial",
            "summarise_identify",
            "write_identify_report",
        ],
        "_records": ["COLUMNS", "append_records", "done_trial_ids", "read_records"],
        "_run": ["run_directory", "run_experiment", "run_metadata"],
        "_stats": [
            "PAPER_TABLE1",
            "AxisError",
            "ErrorTable",
            "error_table",
            "error_tables",
            "garment_summary_markdown",
            "table1_markdown",
        ],
        "_study": ["write_experiment_report"],
        "_trials": [
            "ExperimentConfig",
            "Trial",
            "plan_trials",
            "run_trial",
            "trial_inputs",
            "trial_locator",
            "trial_record",
        ],
    },
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
    "write_identify_report",
    "write_experiment_report",
]
