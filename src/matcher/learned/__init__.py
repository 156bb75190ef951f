"""The reference learned matcher: a siamese patch-feature network after MC-CNN-fast.

The only package of :mod:`matcher` that imports PyTorch (the optional extra ``learn``:
``pip install 'stereoforge[learn]'``); ``import matcher`` never imports it. What is here:

- the networks by name (``registry``: :func:`get_architecture`, :func:`register_architecture`,
  each :class:`Arch` stating its options and halo), and the default one, :class:`PatchNet` and
  its :class:`Architecture` (``network``): 3 x 3 convolutions, L2-normalised features, cosine
  similarity as the matching score;
- :func:`hinge_loss`, :func:`pair_scores` and :func:`batch_pair_scores` (``loss``): the training
  objective, one positive and one negative per patch;
- :func:`load_model` / :func:`save_model` (``model``): weights plus a header;
- :func:`learned_cost` (``cost``) and :func:`match_learned` (``match``): whole-image inference
  through :func:`matcher.cost.aggregate_cost` and :func:`matcher.select.winner_takes_all`.

``matcher.resolve_matcher("learned:MODEL.pt")`` wraps a model file as a MATCHER.
"""

from matcher.learned.cost import COST_SCALE, features, learned_cost
from matcher.learned.loss import MARGIN, batch_pair_scores, hinge_loss, pair_scores
from matcher.learned.match import match_learned, resolve_device
from matcher.learned.model import (
    INFERENCE_DEFAULTS,
    LearnedModel,
    ModelError,
    load_model,
    model_bytes,
    save_model,
)
from matcher.learned.network import ARCHITECTURE, Architecture, PatchNet, standardise
from matcher.learned.registry import (DEFAULT_ARCHITECTURE, Arch, architectures, get_architecture,
                                      register_architecture)

__all__ = [
    "ARCHITECTURE",
    "Arch",
    "Architecture",
    "COST_SCALE",
    "DEFAULT_ARCHITECTURE",
    "INFERENCE_DEFAULTS",
    "LearnedModel",
    "MARGIN",
    "ModelError",
    "PatchNet",
    "architectures",
    "batch_pair_scores",
    "features",
    "get_architecture",
    "hinge_loss",
    "learned_cost",
    "load_model",
    "match_learned",
    "model_bytes",
    "pair_scores",
    "register_architecture",
    "resolve_device",
    "save_model",
    "standardise",
]
