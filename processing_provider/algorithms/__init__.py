"""The fotogeo Processing algorithms: one class per capability, each a thin call of one fotogeo tool."""
from .orient import CompareModelsAlgorithm, OrientAlgorithm
from .pcafusion import PcaFusionAlgorithm
from .points import LayerToPointsAlgorithm, PointsToLayerAlgorithm
from .register import RegisterAlgorithm

#: every algorithm the provider offers (ids: pcafusion, register, orient, comparemodels, pointstolayer,
#: layertopoints)
ALGORITHMS = (PcaFusionAlgorithm, RegisterAlgorithm, OrientAlgorithm, CompareModelsAlgorithm,
              PointsToLayerAlgorithm, LayerToPointsAlgorithm)
