"""The joint kinds mechsolve knows, by their key in the file: one line per kind.

A new kind is a module of its own beside the others (a :class:`~mechsolve.joints.base.Joint`
and its :class:`~mechsolve.joints.base.Constraint`) and one line here.
"""

from __future__ import annotations

from mechsolve.joints.base import Joint
from mechsolve.joints.cam_contact import CamContact
from mechsolve.joints.gear import GearJoint
from mechsolve.joints.rack import RackJoint
from mechsolve.joints.revolute import PinJoint
from mechsolve.joints.slider import SliderJoint

KINDS: dict[str, type[Joint]] = {
    PinJoint.kind: PinJoint,
    SliderJoint.kind: SliderJoint,
    GearJoint.kind: GearJoint,
    RackJoint.kind: RackJoint,
    CamContact.kind: CamContact,
}
