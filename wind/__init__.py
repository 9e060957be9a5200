"""Wind for the testbed: steady wind with height profile, Dryden turbulence, 1-cos gusts.

Pure numpy/scipy (no JSBSim): the simulation samples a :class:`WindField`
once per outer-loop step and pushes the vector into JSBSim's
``atmosphere/wind-{east,north,down}-fps`` (JSBSim's own Dryden model fades at
low airspeed and uses altitude ASL, so it is not used).

Conventions: wind vectors are ENU m/s, the direction the air moves TOWARD;
configured directions are meteorological "from", deg clockwise from north;
heights are AGL in m. See :mod:`wind.field` for the protocol,
:mod:`wind.config` for the YAML block.
"""

from wind.config import (
    GustConfig,
    ProfileConfig,
    RandomGustsConfig,
    TurbulenceConfig,
    WindConfig,
    parse_wind,
    wind_from_config,
)
from wind.dryden import SEVERITY_W20_MPS, DrydenTurbulence, dryden_scales
from wind.field import CalmWind, CompositeWind, WindField, effective_speed, from_deg_of, toward_unit
from wind.gust import Gust, GustTrain
from wind.steady import LogLawProfile, PowerLawProfile, SteadyWind, UniformProfile

__all__ = [
    "SEVERITY_W20_MPS",
    "CalmWind",
    "CompositeWind",
    "DrydenTurbulence",
    "Gust",
    "GustConfig",
    "GustTrain",
    "LogLawProfile",
    "PowerLawProfile",
    "ProfileConfig",
    "RandomGustsConfig",
    "SteadyWind",
    "TurbulenceConfig",
    "UniformProfile",
    "WindConfig",
    "WindField",
    "dryden_scales",
    "effective_speed",
    "from_deg_of",
    "parse_wind",
    "toward_unit",
    "wind_from_config",
]
