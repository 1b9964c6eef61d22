"""somite: embodied, self-organizing, modular neural controllers for 2-D voxel-based soft robots.

An implementation of Pigozzi & Medvet, "Evolving Modularity in Soft Robots through an Embodied
and Self-Organizing Neural Controller" (Artificial Life, 2022).
"""

__version__ = "0.1.0"
