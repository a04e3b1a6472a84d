"""Magnetic soft robots on PyElastica (Yao et al. 2023).

Forcing classes to add to your own PyElastica simulations (``sim.add_forcing_to(rod).using(...)``),
field sources, magnetization patterns, the equivalent circular section of a band, a frictional
ground with an adjustable tolerance, robot presets and a simulation builder. SI units throughout.
"""

from .batch import BatchedRobots, BatchedSimulationDiverged, SpatialFieldNotSupported
from .field_csv import FieldCSVError, read_field_csv, write_field_csv
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
from .interaction import MagneticInteraction
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
    SimulationDiverged,
    build_simulation,
)
from .spatial_fields import (
    ConstantGradientField,
    CurrentLoopField,
    CurrentLoopsField,
    FieldMap,
    FieldMapDomainError,
    FieldSum,
    HelmholtzCoils,
    MaxwellCoils,
    PointDipoleField,
    SpatialFieldError,
    Waypoints,
)
from .units import MM_MG_S, SI, UnitSystem
from .viscoelastic import KelvinVoigtDamping

__version__ = "0.1.0"

__all__ = [
    "SpatialFieldNotSupported",
    "UniformField",
    "Waypoints",
    "SpatialFieldError",
    "PointDipoleField",
    "ConstantGradientField",
    "MaxwellCoils",
    "HelmholtzCoils",
    "FieldSum",
    "FieldMapDomainError",
    "FieldMap",
    "CurrentLoopsField",
    "CurrentLoopField",
    "BatchedRobots",
    "BatchedSimulationDiverged",
    "ConstantField",
    "ControlledField",
    "DampingSpec",
    "FieldCSVError",
    "FieldValueError",
    "FrictionalGroundContact",
    "GroundSpec",
    "InteractionSpec",
    "KelvinVoigtDamping",
    "LegacyInternalDamping",
    "MM_MG_S",
    "MagneticInteraction",
    "MagneticRodSimulator",
    "MagneticTorques",
    "MagnetizationSegment",
    "OpenLoopResult",
    "RampedField",
    "RelativeVelocityDamping",
    "RobotSimulation",
    "RobotSpec",
    "RotatingField",
    "SI",
    "SimulationDiverged",
    "TabulatedField",
    "UnitSystem",
    "YAO2023_MAGNETIZATION",
    "YAO2023_MASS_SCALE",
    "build_simulation",
    "element_centres",
    "equivalent_radius",
    "evaluate_field",
    "hu2018_robot",
    "magnetization_from_function",
    "read_field_csv",
    "rectangular_band_rod",
    "robot_by_name",
    "run_open_loop",
    "segments_magnetization",
    "set_shear_coefficient",
    "shear_coefficient",
    "sinusoidal_magnetization",
    "two_segment_magnetization",
    "uniform_magnetization",
    "write_field_csv",
    "write_trajectory_csv",
    "yao2023_magnetization",
    "yao2023_robot",
]
