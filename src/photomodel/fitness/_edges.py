"""Outline evidence and the score of a pose, with each patch of the model free to slide a
little.

The ``soft`` fitness is ``S_in - S_out``: the inner points' agreement minus the band's. Two
kinds of scene score alike with it, and a cell must tell them apart:

* the garment, half hidden by a gripper: the hidden half disagrees inside (``S_in`` about
  0.6), the visible outline is sharp (fitness about 0.3);
* a plain model laid inside a larger region of about its colour (a grey sock on a grey
  object): everything agrees inside and much of the band agrees too (``S_in`` 0.85-0.95,
  fitness about 0.3-0.4).

The outline tells them apart. Each inner-ring point has a band point just outside it
(:attr:`~photomodel.fitness.ModelSamples.table_out`); the pair shows the model's edge when
the inner point agrees with the model (``a_in``) and the band point does not look like the
garment there (``1 - a_out``). The evidence is the mean of ``a_in (1 - a_out)`` over the
pairs and both cameras, at the offsets the fitness found for the pose, with the inner ring's
colour mixed with the band's as the fitness expects it (``SoftMatch.edge_mix``). A garment
in full view scores about 0.7, a visible half about 0.5, a model lying in a region of its
colour about 0.2-0.3 (the identification experiment's scenes).

``locate``'s score is the mean of the fitness and this evidence, measured with **patch
slack** (:class:`ScoreSlack`): the model is cut into square cells (20 mm) and each cell's
samples may slide in the model plane by up to 1 mm (steps of 0.5 mm), on its own, to where
its share of the score is highest. A folded garment is not a rigid sheet: the cloth beside a
fold is pulled towards its crest by a few millimetres, so a narrow stripe or an outline that
the pose and strain put right on one side of a fold lies a stripe's width off on the other,
and a rigid score would reject a wrinkled striped garment at a good pose. The slack lifts a
wrong model's best score a little too, so the threshold is calibrated on the slack score.
The pose itself stays the rigid (strained) one; the slack only measures how well it explains the
images.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from photomodel.fitness._samples import ModelSamples
from photomodel.fitness._soft import SoftFitness

__all__ = ["NO_SLACK", "ScoreSlack", "ScoreTerms", "edge_evidence", "score_terms"]


@dataclass(frozen=True)
class ScoreSlack:
    """How far each patch of the model may slide on its own when a pose is scored.

    Attributes
    ----------
    cell_mm : float
        Side of the square cells of the model plane whose samples slide together, mm.
    max_shift_mm : float
        Largest slide along each model axis, mm.
    step_mm : float
        Step of the slides tried (a square grid of ``(2 max / step + 1)**2`` slides).
    """

    cell_mm: float = 20.0
    max_shift_mm: float = 1.0
    step_mm: float = 0.5

    def __post_init__(self) -> None:
        if not (self.cell_mm > 0 and self.max_shift_mm >= 0 and self.step_mm > 0):
            raise ValueError(f"ScoreSlack: expected positive sizes, got {self}")

    def shifts_mm(self) -> NDArray[np.float64]:
        """The slides (S, 2) in model x and y, mm, no slide first."""
        n = int(np.floor(self.max_shift_mm / self.step_mm + 1e-9))
        steps = np.arange(-n, n + 1) * self.step_mm
        grid = np.stack(np.meshgrid(steps, steps, indexing="ij"), -1).reshape(-1, 2)
        return grid[np.argsort(np.hypot(grid[:, 0], grid[:, 1]), kind="stable")]


@functools.lru_cache(maxsize=16)
def _shifts_mm(slack: ScoreSlack) -> NDArray[np.float64]:
    """``slack.shifts_mm()``, kept: the same at every score (callers copy it)."""
    return np.ascontiguousarray(slack.shifts_mm())


NO_SLACK = ScoreSlack(max_shift_mm=0.0)
"""Every sample where the pose puts it (the rigid score)."""

AGREEING_CELL = 0.75
"""Mean inner agreement (both cameras) from which a cell's inside counts as seen."""

OUTLINE_CELL_PAIRS = 3
"""Fewest outline pairs (inner-ring point and band point) of a cell on the outline."""


@dataclass(frozen=True)
class ScoreTerms:
    """The terms of a pose's score.

    Attributes
    ----------
    fitness : float
        The fitness at the pose (no slack).
    edge_evidence : float
        The outline evidence at the pose (no slack), in [0, 1].
    score : float
        The score in [0, 1]: the mean of the fitness (clipped to [0, 1]) and the outline
        evidence, each cell's samples slid to where their share of the two is highest.
    slid_fraction : float
        Share of the cells whose best place is not where the pose puts them.
    visible_outline : float
        The outline evidence of the cells on the model's outline whose inside agrees (inner
        agreement over :data:`AGREEING_CELL`), each at its best slide, in [0, 1]; 0 when no
        outline cell agrees, NaN for samples without outline pairs. The garment, even half
        hidden, shows its outline where its inside is seen (0.65-0.95); a model lying inside
        a larger region of its colour does not (0.3-0.45).
    visible_outline_cells : int
        The outline cells that agree, of which ``visible_outline`` is the mean.
    """

    fitness: float
    edge_evidence: float
    score: float
    slid_fraction: float
    visible_outline: float = float("nan")
    visible_outline_cells: int = 0


def _cell_labels(points_mm: NDArray[np.float64], cell_mm: float
                 ) -> tuple[NDArray[np.intp], int]:
    """The cell (0..C-1) of each model point (N, 3) and the number of cells C."""
    ij = np.floor(points_mm[:, :2] / cell_mm).astype(np.int64)
    key = (ij[:, 0] - ij[:, 0].min()) * (int(np.ptp(ij[:, 1])) + 1) + (ij[:, 1] - ij[:, 1].min())
    _, labels = np.unique(key, return_inverse=True)
    return labels.reshape(-1), int(labels.max()) + 1


def _sample_cells(samples: ModelSamples, cell_mm: float
                  ) -> tuple[NDArray[np.intp], NDArray[np.intp], int]:
    """The cells of ``samples``' inner and band points (:func:`_cell_labels`, C-contiguous)
    and their number, kept with the samples: a score asks for the same ones at every pose."""
    def make() -> tuple[NDArray[np.intp], NDArray[np.intp], int]:
        labels, cells = _cell_labels(np.concatenate([samples.p_in, samples.p_out]), cell_mm)
        n_in = len(samples.p_in)
        return (np.ascontiguousarray(labels[:n_in]), np.ascontiguousarray(labels[n_in:]),
                cells)

    return samples.kept.get(("cells", cell_mm), make)


def score_terms(fitness: SoftFitness, A_cam1_model: NDArray[np.float64],
                slack: ScoreSlack | None = None) -> ScoreTerms:
    """Fitness, outline evidence and score of a pose (see the module docstring).

    Parameters
    ----------
    fitness : SoftFitness
        The fitness at the level and camera blur of the score (level 0 for ``locate``).
    A_cam1_model : ndarray (4, 4)
        Map of model points into camera 1: a pose, or a strained one.
    slack : ScoreSlack, optional
        Default ``ScoreSlack()``; :data:`NO_SLACK` for the rigid score.

    Returns
    -------
    ScoreTerms
        With no slack, ``score`` is ``0.5 * (clip(fitness) + clip(edge_evidence))``.
    """
    slack = ScoreSlack() if slack is None else slack
    A = np.asarray(A_cam1_model, dtype=np.float64).reshape(4, 4)
    fitness.evaluate_transforms(A[None])       # the offsets of both cameras at this pose
    terms = fitness.last_terms[0]
    penalty = float(np.mean(terms[:, 1] - terms[:, 2] - terms[:, 0]))   # the chroma offsets'
    s = fitness.samples
    n_in, n_out = len(s.p_in), len(s.p_out)
    cell_in, cell_out, cells = _sample_cells(s, slack.cell_mm)
    sums = fitness.slack_sums(A, _shifts_mm(slack).copy(), terms[:, 3:], cell_in, cell_out, cells)
    sums = sums.mean(axis=1)                   # (S, 3, C): the cameras' mean
    n_pairs = int(np.count_nonzero(s.table_out >= 0)) if s.table_out is not None else 0
    fit_cell = sums[:, 0] / n_in - sums[:, 1] / max(n_out, 1)
    edge_cell = sums[:, 2] / max(n_pairs, 1)
    best = np.argmax(fit_cell + edge_cell, axis=0)     # ties keep the smaller slide
    columns = np.arange(cells)
    fit = float(fit_cell[best, columns].sum()) - penalty
    edges = float(edge_cell[best, columns].sum())
    score = 0.5 * (float(np.clip(fit, 0.0, 1.0)) + float(np.clip(edges, 0.0, 1.0)))
    outline, outline_cells = _visible_outline(s, sums[best, :, columns].T, cell_in, cells)
    return ScoreTerms(float(fit_cell[0].sum()) - penalty, float(edge_cell[0].sum()), score,
                      float(np.mean(best > 0)), outline, outline_cells)


def _visible_outline(samples: ModelSamples, cell_sums: NDArray[np.float64],
                     cell_in: NDArray[np.intp], cells: int) -> tuple[float, int]:
    """Mean outline evidence (and count) of the outline cells whose inside agrees, from
    each cell's sums (3, C) at its chosen slide (:attr:`ScoreTerms.visible_outline`)."""
    if samples.table_out is None:
        return float("nan"), 0
    inner = np.bincount(cell_in, minlength=cells).astype(np.float64)
    pairs = np.bincount(cell_in[samples.table_out >= 0], minlength=cells).astype(np.float64)
    agreeing = cell_sums[0] > AGREEING_CELL * np.maximum(inner, 1.0)
    outline = agreeing & (pairs >= OUTLINE_CELL_PAIRS)
    n = int(np.count_nonzero(outline))
    if n == 0:
        return 0.0, 0
    return float(np.mean(cell_sums[2][outline] / pairs[outline])), n


def edge_evidence(fitness: SoftFitness, T_cam1_model: NDArray[np.float64]) -> float:
    """Share of the model's outline that both cameras see as an edge at a pose, in [0, 1].

    Parameters
    ----------
    fitness : SoftFitness
        The fitness at the level and camera blur of the pose's score (level 0 for
        ``locate``).
    T_cam1_model : ndarray (4, 4)

    Returns
    -------
    float
        Mean of ``a_in (1 - a_out)`` over the inner-ring points with a band point and both
        cameras (0 for a model without such points); a point outside an image counts 0.
    """
    return score_terms(fitness, T_cam1_model, NO_SLACK).edge_evidence
