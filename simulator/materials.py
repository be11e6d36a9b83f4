"""Material properties every triangle carries: radar reflectance, LIDAR reflectivity, colour.

The scene stores them per triangle (see `simulator.scene.Scene`) so that a ray hit's primitive
id yields its material with one numpy gather.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Material:
    """Surface properties.

    radar_reflectance : the per-object `ref_i` of thesis eq. 3.5.3 (summed per radar cell).
    lidar_reflectivity : 0..1, published as point intensity; 0 means no return (specular water).
    colour_rgb : camera albedo, 0..255 per channel.
    """

    name: str
    radar_reflectance: float
    lidar_reflectivity: float
    colour_rgb: tuple[int, int, int]


# Thesis 4.1: vessels were given "a very high reflection value of about 100" so that the
# SOCA-CFAR detects them; natural surfaces stay around 1 and calm water well below it.
# Columns: name, radar_reflectance, lidar_reflectivity, colour_rgb.
GRASS = Material("grass", 0.5, 0.45, (86, 125, 60))
SHORE = Material("shore", 0.8, 0.35, (140, 125, 95))
RIVERBED = Material("riverbed", 0.2, 0.2, (90, 80, 60))
# The thesis's water is "a two-dimensional collision mesh" (3.5.3) that Unity's LIDAR raycasts
# hit, so water returns exist (weak), and navigation must remove them as the thesis did.
WATER = Material("water", 0.05, 0.05, (52, 92, 120))
STEEL = Material("steel", 60.0, 0.6, (120, 120, 128))
VESSEL = Material("vessel", 100.0, 0.7, (200, 200, 205))
# A steel navigation buoy carries a radar reflector: as bright as a hull to the radar (ours).
BUOY = Material("buoy", 100.0, 0.6, (200, 60, 40))
WOOD = Material("wood", 2.0, 0.4, (110, 80, 50))
FOLIAGE = Material("foliage", 1.0, 0.5, (45, 95, 40))
BRICK = Material("brick", 20.0, 0.5, (170, 90, 70))
ROOF = Material("roof", 20.0, 0.3, (90, 50, 45))
