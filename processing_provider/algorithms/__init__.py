"""The fotogeo Processing algorithms: one class per capability, each a thin call of one fotogeo tool."""
from .demo import DemoAlgorithm
from .features import MatchFeaturesAlgorithm
from .matching import MeasureTargetsAlgorithm, TransferPointsAlgorithm
from .orient import CompareModelsAlgorithm, OrientAlgorithm
from .pcafusion import PcaFusionAlgorithm
from .points import LayerToPointsAlgorithm, PointsToLayerAlgorithm
from .register import RegisterAlgorithm

#: every algorithm the provider offers
ALGORITHMS = (PcaFusionAlgorithm, MatchFeaturesAlgorithm, RegisterAlgorithm, OrientAlgorithm, CompareModelsAlgorithm,
              TransferPointsAlgorithm, MeasureTargetsAlgorithm, PointsToLayerAlgorithm, LayerToPointsAlgorithm,
              DemoAlgorithm)
