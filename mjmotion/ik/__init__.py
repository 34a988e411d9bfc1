"""Inverse kinematics for hit-point adaptation (seed 003 §1.7, §1.10, §2.1–2.2).

``chains`` (which joints move, their freedoms, limits and stiffness), ``dls`` (damped least
squares with MuJoCo Jacobians), ``ccd`` (cyclic coordinate descent, the seed's solver) and ``nlp``
(the CasADi/IPOPT programme per frame and over a whole shot). All share the coordinates ``δ`` of
:mod:`mjmotion.ik.chains`; ``nlp`` imports CasADi, so import it only where it is used.
"""

from .chains import Chain, ChainJoint, ChainKinematics, Effector, build_chain
from .dls import IKResult

__all__ = ["Chain", "ChainJoint", "ChainKinematics", "Effector", "IKResult", "build_chain"]
