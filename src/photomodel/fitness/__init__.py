"""Fitness functions over whole pose populations: the paper's eq. (9) with hue matching, and
the ``soft`` fitness (graded log-opponent colour, sub-pixel, over a feature pyramid)."""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_base": ["Fitness"],
        "_edges": ["NO_SLACK", "ScoreSlack", "ScoreTerms", "edge_evidence", "score_terms"],
        "_hue": ["HueMatch", "hue_code_image", "hue_codes", "hue_codes_match"],
        "_light": ["light_offset_candidates"],
        "_paper": ["FITNESS_PRESETS", "PaperFitness", "PaperVotes", "make_fitness"],
        "_prepared": ["PreparedModel", "as_prepared"],
        "_protocols": ["KernelFitness", "KernelNormalEquations"],
        "_samples": ["ModelSamples", "SampleDrawer", "SampleSpacing", "model_samples"],
        "_scan": ["ScanConfig", "ScanResult", "prepare_scan", "relight_scan", "scan_flat_poses",
                  "scan_spacing"],
        "_soft": ["SoftFitness", "SoftMatch", "StereoFeatures", "level_spacing"],
    },
)

__all__ = [
    "FITNESS_PRESETS",
    "NO_SLACK",
    "Fitness",
    "HueMatch",
    "KernelFitness",
    "KernelNormalEquations",
    "ModelSamples",
    "PaperFitness",
    "PaperVotes",
    "PreparedModel",
    "SampleDrawer",
    "SampleSpacing",
    "ScanConfig",
    "ScanResult",
    "ScoreSlack",
    "ScoreTerms",
    "SoftFitness",
    "SoftMatch",
    "StereoFeatures",
    "edge_evidence",
    "hue_code_image",
    "hue_codes",
    "hue_codes_match",
    "level_spacing",
    "light_offset_candidates",
    "make_fitness",
    "as_prepared",
    "model_samples",
    "prepare_scan",
    "relight_scan",
    "scan_flat_poses",
    "scan_spacing",
    "score_terms",
]
