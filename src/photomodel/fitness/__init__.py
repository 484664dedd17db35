"""Fitness functions over whole pose populations: the paper's eq. (9) and hue matching."""

from photomodel.fitness._base import Fitness
from photomodel.fitness._hue import HueMatch, hue_code_image, hue_codes, hue_codes_match
from photomodel.fitness._paper import FITNESS_PRESETS, PaperFitness, PaperVotes, make_fitness

__all__ = [
    "FITNESS_PRESETS",
    "Fitness",
    "HueMatch",
    "PaperFitness",
    "PaperVotes",
    "hue_code_image",
    "hue_codes",
    "hue_codes_match",
    "make_fitness",
]
