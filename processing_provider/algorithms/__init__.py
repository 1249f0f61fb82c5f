"""The fotogeo Processing algorithms: one class per capability, each a thin call of one fotogeo tool."""
from .pcafusion import PcaFusionAlgorithm
from .points import LayerToPointsAlgorithm, PointsToLayerAlgorithm
from .register import RegisterAlgorithm

#: every algorithm the provider offers (ids: pcafusion, register, pointstolayer, layertopoints)
ALGORITHMS = (PcaFusionAlgorithm, RegisterAlgorithm, PointsToLayerAlgorithm, LayerToPointsAlgorithm)
