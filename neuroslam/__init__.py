"""neuroslam: a fast, correct implementation of NeuroSLAM, the brain-inspired 4-DoF SLAM system."""

__version__ = "0.1.0"
