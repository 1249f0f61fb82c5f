"""The fotogeo Processing algorithms: one module per tool (the same stem as ``fotogeo/tools/``
and ``fotogeo/cli/``), each a thin call of that tool."""
from .compare import CompareModelsAlgorithm
from .coreg import CoregAlgorithm
from .demo import DemoAlgorithm
from .dsm import DsmAlgorithm
from .fuse import PcaFusionAlgorithm
from .interior import InteriorAlgorithm
from .match import MatchFeaturesAlgorithm
from .mosaic import MosaicAlgorithm
from .orient import OrientAlgorithm
from .ortho import OrthoAlgorithm
from .points import LayerToPointsAlgorithm, PointsToLayerAlgorithm
from .register import RegisterAlgorithm
from .register_batch import RegisterBatchAlgorithm
from .rpc_bias import RpcBiasAlgorithm
from .targets import MeasureTargetsAlgorithm
from .transfer import TransferPointsAlgorithm
from .triangulate import TriangulateAlgorithm

#: every algorithm the provider offers
ALGORITHMS = (PcaFusionAlgorithm, MatchFeaturesAlgorithm, RegisterAlgorithm, OrientAlgorithm, CompareModelsAlgorithm,
              TransferPointsAlgorithm, MeasureTargetsAlgorithm, PointsToLayerAlgorithm, LayerToPointsAlgorithm,
              RpcBiasAlgorithm, DemoAlgorithm, RegisterBatchAlgorithm, TriangulateAlgorithm, CoregAlgorithm,
              InteriorAlgorithm, OrthoAlgorithm, MosaicAlgorithm, DsmAlgorithm)
