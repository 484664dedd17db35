# The subpackage's public names (lazy_loader.attach_stub reads this file; type
# checkers read it as the package's stub). One list: add a name here only.

from ._base import (
    Fitness,
)
from ._edges import (
    NO_SLACK,
    ScoreSlack,
    ScoreTerms,
    edge_evidence,
    score_terms,
)
from ._hue import (
    HueMatch,
    hue_code_image,
    hue_codes,
    hue_codes_match,
)
from ._light import (
    light_offset_candidates,
)
from ._paper import (
    FITNESS_PRESETS,
    PaperFitness,
    PaperVotes,
    make_fitness,
)
from ._prepared import (
    PreparedModel,
    as_prepared,
)
from ._protocols import (
    KernelFitness,
    KernelNormalEquations,
    kernel_normal_equations,
    kernel_values,
)
from ._samples import (
    ModelSamples,
    SampleDrawer,
    SampleSpacing,
    model_samples,
)
from ._scan import (
    ScanConfig,
    ScanResult,
    prepare_scan,
    relight_scan,
    scan_flat_poses,
    scan_spacing,
)
from ._scene import (
    SCENE_LEVEL,
    Region,
    SceneConfig,
    SceneRegions,
    border_band,
    scene_regions,
)
from ._soft import (
    SoftFitness,
    SoftMatch,
    StereoFeatures,
    level_spacing,
)

__all__ = [
    "FITNESS_PRESETS",
    "Fitness",
    "HueMatch",
    "KernelFitness",
    "KernelNormalEquations",
    "ModelSamples",
    "NO_SLACK",
    "PaperFitness",
    "PaperVotes",
    "PreparedModel",
    "Region",
    "SCENE_LEVEL",
    "SampleDrawer",
    "SampleSpacing",
    "ScanConfig",
    "ScanResult",
    "SceneConfig",
    "SceneRegions",
    "ScoreSlack",
    "ScoreTerms",
    "SoftFitness",
    "SoftMatch",
    "StereoFeatures",
    "as_prepared",
    "border_band",
    "edge_evidence",
    "hue_code_image",
    "hue_codes",
    "hue_codes_match",
    "kernel_normal_equations",
    "kernel_values",
    "level_spacing",
    "light_offset_candidates",
    "make_fitness",
    "model_samples",
    "prepare_scan",
    "relight_scan",
    "scan_flat_poses",
    "scan_spacing",
    "scene_regions",
    "score_terms",
]
