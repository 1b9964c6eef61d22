"""Reassembly: a controller for a receiver body built from modules of donor controllers.

Reassembly (:func:`reassemble`) cuts each donor along its partition
(:func:`~somite.modules.module.cut`) and puts the chosen modules, possibly of different donors
and shapes, into the receiver body with :func:`~somite.modules.graft.graft`, adding no edge
between modules (decisions.md, "Modules"; paper section 5.2.1). A donor module is placed with
its bounding-box corner on the receiver module's (decisions.md; original-system.md section 6.3).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from ..brain.genome import Genome
from ..errors import bad
from ..sim.body import Body
from ..sim.partition import Partition
from .graft import Graft, GraftReport, graft
from .module import CutRatio, Disassembly, Voxel, _check_partition, cut, pooled


@dataclass(frozen=True, repr=False)
class Take:
    """One part of a reassembly: module ``label`` of ``donor`` cut along ``partition``."""

    donor: Genome
    partition: Partition
    label: str

    def __repr__(self) -> str:
        return f"Take({self.label!r} of {self.donor!r})"


@dataclass(frozen=True, repr=False)
class Reassembly:
    """A reassembled controller and what the reassembly cost (the result of :func:`reassemble`).

    Attributes
    ----------
    genome : Genome
        The reassembled controller, valid for the receiver body.
    partition : Partition
        The receiver's partition.
    takes : tuple of Take
        Where each receiver module came from, in ``partition.modules`` order.
    grafts : tuple of GraftReport
        What each receiver module kept, dropped and added, same order.
    ratios : tuple of CutRatio
        The cut ratio (eta) of each donor module in its donor, same order.
    pooled : CutRatio
        The authors' eta over the distinct donors.
    """

    genome: Genome
    partition: Partition
    takes: tuple[Take, ...]
    grafts: tuple[GraftReport, ...]
    ratios: tuple[CutRatio, ...]
    pooled: CutRatio

    def __repr__(self) -> str:
        return f"Reassembly({self.genome!r}, modules={self.partition.modules})"

    @property
    def homogeneous(self) -> bool:
        """Whether every donor has the receiver's shape."""
        return all(t.donor.body.shape == self.partition.shape for t in self.takes)


def reassemble(
    receiver_body: Body,
    receiver_partition: Partition,
    parts: Mapping[str, Take | tuple[Genome, Partition, str]],
) -> Reassembly:
    """Build a controller for ``receiver_body`` from modules of donor controllers.

    Parameters
    ----------
    receiver_body : Body
        The body of the new robot (for a homogeneous reassembly, the donors' body).
    receiver_partition : Partition
        A partition of the receiver's shape.
    parts : mapping
        Every module label of ``receiver_partition`` -> a :class:`Take` (or the tuple
        ``(donor genome, donor partition, donor module label)``).

    Returns
    -------
    Reassembly
        The genome, and per module the cut ratio of its donor module and the graft counts.

    Examples
    --------
    The paper's homogeneous worm, back from donor 1 and front from donor 2::

        halves = Partition.preset("worm-halves", "worm")
        reassemble(d1.body, halves, {"back": (d1, halves, "back"), "front": (d2, halves, "front")})
    """
    _check_partition(receiver_partition, receiver_body.shape, "receiver_partition")
    takes = _takes(receiver_partition, parts)
    cuts: dict[int, Disassembly] = {}
    steps = []
    for label, take in zip(receiver_partition.modules, takes):
        # One cut per donor object: a donor giving two modules is cut once.
        key = id(take.donor), id(take.partition)
        if key not in cuts:
            cuts[key] = cut(take.donor, take.partition)
        module = cuts[key].module(take.label)
        target = receiver_partition.voxels_of(label)
        offset = _corner_offset(module.voxels, target)
        steps.append(Graft(label, module, offset, target))
    genome, reports = graft(receiver_body, steps)
    ratios = tuple(cuts[id(t.donor), id(t.partition)].ratio(t.label) for t in takes)
    return Reassembly(
        genome, receiver_partition, takes, reports, ratios, pooled(list(cuts.values()))
    )


def _takes(partition: Partition, parts: Mapping) -> tuple[Take, ...]:
    """Check that ``parts`` gives exactly one donor module per receiver module."""
    if not isinstance(parts, Mapping):
        raise bad("parts", type(parts).__name__, "expected a mapping receiver module -> Take")
    for label in parts:
        if label not in partition.modules:
            raise bad("parts", label, f"not a receiver module; modules are {partition.modules}")
    takes = []
    for label in partition.modules:
        if label not in parts:
            raise bad("parts", label, "receiver module has no donor module")
        part = parts[label]
        if not isinstance(part, Take):
            try:
                part = Take(*part)
            except TypeError:
                raise bad(f"parts[{label}]", part, "expected (donor, partition, label)") from None
        if not isinstance(part.donor, Genome):
            raise bad(f"parts[{label}].donor", type(part.donor).__name__, "expected a Genome")
        _check_partition(part.partition, part.donor.body.shape, f"parts[{label}].partition")
        if part.label not in part.partition.modules:
            raise bad(
                f"parts[{label}].label", part.label,
                f"not a donor module; modules are {part.partition.modules}",
            )
        takes.append(part)
    return tuple(takes)


def _corner_offset(donor: Sequence[Voxel], receiver: Sequence[Voxel]) -> Voxel:
    """Translation that puts the donor's bounding-box corner on the receiver's (decisions.md)."""
    return (
        min(x for x, _ in receiver) - min(x for x, _ in donor),
        min(y for _, y in receiver) - min(y for _, y in donor),
    )


__all__ = [
    "Reassembly",
    "Take",
    "reassemble",
]
