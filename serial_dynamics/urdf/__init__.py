"""URDF -> Model: the XML checks, the tree walk, transmissions, lumping.

    loader.py         load_model: parse (yourdfpy, no meshes), pick the chain, lump, build
    xml_checks.py     every XML error names the element, attribute and what is expected
    tree.py           cycles and branches, the default tip
    transmissions.py  reflected rotor inertia from <transmission>
"""
from .loader import HeldJointsWarning, load_model
from ..model.errors import URDFError

__all__ = ["load_model", "HeldJointsWarning", "URDFError"]
