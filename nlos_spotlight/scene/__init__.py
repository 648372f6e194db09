"""Scene format, mesh I/O."""

from .format import Ambient, Camera, HiddenRegion, Human, Material, Projector, Scene, Shape, TriMesh
from .io import load_scene, save_scene, scene_from_dict, scene_to_dict
from .meshio import load_mesh, save_mesh

__all__ = ["Ambient", "Camera", "HiddenRegion", "Human", "Material", "Projector", "Scene", "Shape", "TriMesh",
           "load_scene", "save_scene", "scene_from_dict", "scene_to_dict", "load_mesh", "save_mesh"]
