"""Fitness functions over whole pose populations: the paper's eq. (9) with hue matching, and
the ``soft`` fitness (graded log-opponent colour, sub-pixel, over a feature pyramid)."""

from photomodel.fitness._base import Fitness
from photomodel.fitness._edges import NO_SLACK, ScoreSlack, ScoreTerms, edge_evidence, score_terms
from photomodel.fitness._hue import HueMatch, hue_code_image, hue_codes, hue_codes_match
from photomodel.fitness._light import light_offset_candidates
from photomodel.fitness._paper import FITNESS_PRESETS, PaperFitness, PaperVotes, make_fitness
from photomodel.fitness._protocols import KernelFitness, KernelNormalEquations
from photomodel.fitness._samples import ModelSamples, SampleSpacing, model_samples
from photomodel.fitness._scan import (
    ScanConfig,
    ScanResult,
    prepare_scan,
    relight_scan,
    scan_flat_poses,
)
from photomodel.fitness._soft import SoftFitness, SoftMatch, StereoFeatures, level_spacing

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
    "model_samples",
    "prepare_scan",
    "relight_scan",
    "scan_flat_poses",
    "score_terms",
]
