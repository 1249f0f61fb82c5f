"""Geometric models sharing one protocol (see :mod:`fotogeo.models.base`) and one RANSAC."""
from .base import MODELS, Model, Normalisation, get_model, model_from_dict, register_model
from .collinearity import Collinearity
from .planar import Affine, Projective, Similarity
from .polynomial import AffineHeight, Bilinear, Poly1, Poly2, Poly3, Poly3D1, Poly3D2, Poly3D3
from .ransac import RansacResult, RobustFit, ransac, robust_refit
from .rfm import (RFM, RFMCommon, RFMCommonImageToGround, RFMCommonPlain, RFMImageToGround, RFMPlain,
                  RFMPlainImageToGround, RFMPoly, RFMPolyImageToGround, RFMPolyPlain)
from .spatial import DLT, FittedModel, IllPosedWarning

__all__ = ["MODELS", "Model", "Normalisation", "get_model", "model_from_dict", "register_model",
           "Affine", "Projective", "Similarity", "RansacResult", "RobustFit", "ransac", "robust_refit",
           "DLT", "FittedModel", "IllPosedWarning", "AffineHeight", "Bilinear", "Poly1", "Poly2", "Poly3",
           "Poly3D1", "Poly3D2", "Poly3D3", "RFM", "RFMCommon", "RFMPoly", "RFMImageToGround",
           "RFMCommonImageToGround", "RFMPolyImageToGround", "RFMPlain", "RFMCommonPlain", "RFMPolyPlain",
           "RFMPlainImageToGround", "Collinearity"]

# the option table lists the model names literally (the QGIS plugin reads it without numpy): one list, checked here
from ..options import ORIENTATION_MODELS  # noqa: E402

if tuple(sorted(MODELS)) != ORIENTATION_MODELS:
    raise ImportError(f"fotogeo.options.ORIENTATION_MODELS {ORIENTATION_MODELS} differs from the registered models "
                      f"{tuple(sorted(MODELS))}: update the list in fotogeo/options/shared.py")
