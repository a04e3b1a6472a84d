"""Magnetic soft robots on PyElastica (Yao et al. 2023).

Forcing classes to add to your own PyElastica simulations (``sim.add_forcing_to(rod).using(...)``),
field sources, magnetization patterns, the equivalent circular section of a band, a frictional
ground with an adjustable tolerance, robot presets and a simulation builder. SI units throughout.
"""

# First, before any kernel loads from numba's cache: a kernel cached with another module's kernel
# inside it would keep the old callee after that module changed (elastica_magnetic._kernel_cache).
from . import _kernel_cache  # noqa: F401  (drops stale cached kernels on import)
from .actuation import CoilCurrents, MagnetPose
from .batch import BatchedRobots, BatchedSimulationDivergedError, SpatialFieldNotSupportedError
from .field_csv import FieldCSVError, read_field_csv, write_field_csv
from .field_maps import FieldMap, FieldMapDomainError
from .fields import (
    ConstantField,
    ControlledField,
    RampedField,
    RotatingField,
    TabulatedField,
    UniformField,
)
from .forcing import (
    FieldValueError,
    LegacyInternalDamping,
    MagneticTorques,
    RelativeVelocityDamping,
    evaluate_field,
)
from .ground import FrictionalGroundContact
from .insertion import Advancer, InsertionClamp
from .interaction import MagneticInteraction
from .magnet_fields import CuboidMagnetField, CylinderMagnetField, MagnetMap, magnet_map
from .magnetization import (
    YAO2023_MAGNETIZATION,
    MagnetizationSegment,
    element_centres,
    magnetization_from_function,
    segments_magnetization,
    sinusoidal_magnetization,
    two_segment_magnetization,
    uniform_magnetization,
    yao2023_magnetization,
)
from .openloop import OpenLoopResult, run_open_loop, write_trajectory_csv
from .presets import YAO2023_MASS_SCALE, hu2018_robot, robot_by_name, yao2023_robot
from .robot_spec import DampingSpec, GroundSpec, InteractionSpec, RobotSpec
from .section import (
    equivalent_radius,
    rectangular_band_rod,
    set_shear_coefficient,
    shear_coefficient,
)
from .simulation import (
    MagneticRodSimulator,
    RobotSimulation,
    SimulationDivergedError,
    build_simulation,
)
from .spatial_fields import (
    ConstantGradientField,
    CurrentLoopField,
    CurrentLoopsField,
    FieldSum,
    HelmholtzCoils,
    MaxwellCoils,
    PointDipoleField,
    SpatialFieldError,
    Waypoints,
)
from .spec_format import SpecError
from .specfile import load_robot
from .steering import CoilFieldSteering, MagnetBearingSteering
from .uniform_simulation import UniformFieldSimulation, uniform_field_simulation
from .units import MM_MG_S, SI, UnitSystem
from .viscoelastic import KelvinVoigtDamping

__version__ = "0.1.0"

__all__ = [
    # forcing (add to your own PyElastica simulation)
    "evaluate_field",
    "FrictionalGroundContact",
    "KelvinVoigtDamping",
    "LegacyInternalDamping",
    "MagneticInteraction",
    "MagneticTorques",
    "RelativeVelocityDamping",
    # fields: uniform in space (functions of time, T)
    "ConstantField",
    "ControlledField",
    "RampedField",
    "read_field_csv",
    "RotatingField",
    "TabulatedField",
    "UniformField",
    "write_field_csv",
    # fields: varying in space (magnets, coils, maps) and their actuators
    "Advancer",
    "CoilCurrents",
    "CoilFieldSteering",
    "ConstantGradientField",
    "CuboidMagnetField",
    "CurrentLoopField",
    "CurrentLoopsField",
    "CylinderMagnetField",
    "FieldMap",
    "FieldSum",
    "HelmholtzCoils",
    "InsertionClamp",
    "magnet_map",
    "MagnetBearingSteering",
    "MagnetMap",
    "MagnetPose",
    "MaxwellCoils",
    "PointDipoleField",
    "Waypoints",
    # robots and specs
    "DampingSpec",
    "element_centres",
    "equivalent_radius",
    "GroundSpec",
    "hu2018_robot",
    "InteractionSpec",
    "load_robot",
    "magnetization_from_function",
    "MagnetizationSegment",
    "MM_MG_S",
    "rectangular_band_rod",
    "robot_by_name",
    "RobotSpec",
    "segments_magnetization",
    "set_shear_coefficient",
    "shear_coefficient",
    "SI",
    "sinusoidal_magnetization",
    "two_segment_magnetization",
    "uniform_magnetization",
    "UnitSystem",
    "YAO2023_MAGNETIZATION",
    "yao2023_magnetization",
    "YAO2023_MASS_SCALE",
    "yao2023_robot",
    # simulation
    "BatchedRobots",
    "build_simulation",
    "MagneticRodSimulator",
    "OpenLoopResult",
    "RobotSimulation",
    "run_open_loop",
    "uniform_field_simulation",
    "UniformFieldSimulation",
    "write_trajectory_csv",
    # errors
    "BatchedSimulationDivergedError",
    "FieldCSVError",
    "FieldMapDomainError",
    "FieldValueError",
    "SimulationDivergedError",
    "SpatialFieldError",
    "SpatialFieldNotSupportedError",
    "SpecError",
]

#: Names of earlier releases, kept so that users' scripts run (not in ``__all__``; they will go).
BatchedSimulationDiverged = BatchedSimulationDivergedError
SimulationDiverged = SimulationDivergedError
SpatialFieldNotSupported = SpatialFieldNotSupportedError
