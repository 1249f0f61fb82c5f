"""Geometric models sharing one protocol (see :mod:`fotogeo.models.base`) and one RANSAC."""
from .base import MODELS, Model, Normalisation, get_model, model_from_dict, register_model
from .planar import Affine, Projective, Similarity
from .ransac import RansacResult, RobustFit, ransac, robust_refit

__all__ = ["MODELS", "Model", "Normalisation", "get_model", "model_from_dict", "register_model",
           "Affine", "Projective", "Similarity", "RansacResult", "RobustFit", "ransac", "robust_refit"]
