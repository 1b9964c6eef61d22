"""Reassembly: a controller for a receiver body built from modules of donor controllers.

Reassembly (:func:`reassemble`) cuts each donor along its partition
(:func:`~somite.modules.module.cut`) and puts the chosen modules, possibly of different donors
and shapes, into the receiver body with :func:`~somite.modules.graft.graft`, adding no edge
between modules (docs/decisions.md, "Modules"; paper section 5.2.1). A donor module is placed
with its bounding-box corner on the receiver module's (docs/decisions.md, "Reassembly";
docs/original-system.md section 6.3).

The paper's homogeneous reassembly (section 5.2.2) is the default of :func:`receiver_for` and
:func:`paper_takes`: the receiver is donor 1's body and partition, and donor 1 gives every module
but the last one (in the partition's order) while donor 2 gives the last one: the worm's back
half from donor 1 and front half from donor 2; the biped's legs from donor 1, torso from donor 2.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import NamedTuple

from ..brain.genome import Genome
from ..errors import bad
from ..sim.body import Body, Shape
from ..sim.partition import Partition
from .graft import Graft, GraftReport, graft
from .module import CutRatio, Disassembly, Voxel, _check_partition, cut, pooled


class Take(NamedTuple):
    """One part of a reassembly: module ``label`` of ``donor`` cut along ``partition``.

    A plain ``(donor, partition, label)`` tuple is accepted wherever a Take is.
    """

    donor: Genome
    partition: Partition
    label: str


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
    donors : tuple of Disassembly
        Every donor, cut once along its partition: those given to :func:`reassemble` in their
        order, then any other of the takes.
    sources : tuple of int
        For each take, the position of its donor in ``donors``.
    """

    genome: Genome
    partition: Partition
    takes: tuple[Take, ...]
    grafts: tuple[GraftReport, ...]
    donors: tuple[Disassembly, ...]
    sources: tuple[int, ...]

    def __repr__(self) -> str:
        return f"Reassembly({self.genome!r}, modules={self.partition.modules})"

    @property
    def homogeneous(self) -> bool:
        """Whether every donor has the receiver's shape."""
        return all(t.donor.body.shape == self.partition.shape for t in self.takes)

    @property
    def ratios(self) -> tuple[CutRatio, ...]:
        """The cut ratio (eta) of each donor module in its donor, in ``takes`` order."""
        return tuple(self.donors[i].ratio(t.label) for i, t in zip(self.sources, self.takes))

    @property
    def pooled(self) -> CutRatio:
        """The authors' eta over the distinct donors."""
        return pooled(self.donors)

    def to_dict(self) -> dict:
        """The JSON-ready report: donors, receiver, one row per receiver module, pooled eta.

        A module row's ``donor`` is its donor's number (1-based position in ``donors``). NaN
        ratios are written as None (strict JSON).
        """
        modules = [
            _module_row(label, source + 1, take, ratio, counts)
            for label, source, take, ratio, counts in zip(
                self.partition.modules, self.sources, self.takes, self.ratios, self.grafts
            )
        ]
        dropped = ("nodes_dropped", "edges_dropped", "hidden_pruned", "nodes_added")
        return {
            "kind": "homogeneous" if self.homogeneous else "heterogeneous",
            "donors": [
                {
                    "shape": d.donor.body.shape.grid_string(),
                    "partition": d.partition.grid_string(),
                    "nodes": d.donor.n_nodes,
                    "edges": d.donor.n_edges,
                    "cut": d.total.to_dict(),
                }
                for d in self.donors
            ],
            "receiver": {
                "shape": self.genome.body.shape.grid_string(),
                "partition": self.partition.grid_string(),
                "nodes": self.genome.n_nodes,
                "edges": self.genome.n_edges,
            },
            "modules": modules,
            "pooled": self.pooled.to_dict(),
            "dropped": {key: sum(m[key] for m in modules) for key in dropped},
        }


def _module_row(label: str, donor: int, take: Take, ratio: CutRatio, counts: GraftReport):
    counts = counts.to_dict()
    ratio = ratio.to_dict()
    return {
        "module": label,
        "donor": donor,
        "donor_module": take.label,
        "offset_x": counts["offset"][0],
        "offset_y": counts["offset"][1],
        "edges_touching": ratio["n_edges"],
        "edges_cut": ratio["n_cut"],
        "weight_touching": ratio["weight"],
        "weight_cut": ratio["weight_cut"],
        "eta_num": ratio["eta_num"],
        "eta_weight": ratio["eta_weight"],
        **{key[2:]: value for key, value in counts.items() if key.startswith("n_")},
    }


def reassemble(
    receiver_body: Body,
    receiver_partition: Partition,
    parts: Mapping[str, Take | tuple[Genome, Partition, str]],
    donors: Sequence[tuple[Genome, Partition]] = (),
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
    donors : sequence of (Genome, Partition), optional
        Donors to list first in :attr:`Reassembly.donors`, in this order (and cut, even when
        they give no module); a take whose donor and partition are these very objects uses
        that cut.

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
    cuts: dict[tuple[int, int], Disassembly] = {}
    # One cut per donor object: a donor giving two modules is cut once.
    for genome, partition in [*donors, *((t.donor, t.partition) for t in takes)]:
        if (id(genome), id(partition)) not in cuts:
            cuts[id(genome), id(partition)] = cut(genome, partition)
    order = list(cuts)
    sources = tuple(order.index((id(t.donor), id(t.partition))) for t in takes)
    steps = []
    for label, take, source in zip(receiver_partition.modules, takes, sources):
        module = cuts[order[source]].module(take.label)
        target = receiver_partition.voxels_of(label)
        steps.append(Graft(label, module, _corner_offset(module.voxels, target), target))
    genome, reports = graft(receiver_body, steps)
    delays = {g.delay_per_voxel for g in [*(d for d, _ in donors), *(t.donor for t in takes)]}
    if len(delays) > 1:
        raise bad("donors", sorted(delays), "the donors' edges are delayed differently "
                  "(delay_per_voxel): their modules would not run as they did in them")
    if delays and (delay := delays.pop()):
        # The donors' delays go with their modules (issue 72): every edge keeps its law.
        genome = replace(genome, delay_per_voxel=delay)
    return Reassembly(
        genome, receiver_partition, takes, reports, tuple(cuts.values()), sources
    )


def receiver_for(
    donors: Sequence[tuple[Genome, Partition]],
    shape: Shape | str | None = None,
    sensors: str | None = None,
    partition: Partition | str | None = None,
) -> tuple[Body, Partition]:
    """The receiver's body and partition: donor 1's unless told otherwise.

    Without ``sensors``, the body is that of the first donor of the receiver's shape, else the
    paper's sensors; without ``partition``, the partition is that donor's, else the paper's.
    ``partition`` may be anything :meth:`Partition.parse` reads.
    """
    if shape is None:
        shape = donors[0][0].body.shape
    shape = Shape.parse(shape) if isinstance(shape, str) else shape
    same = [(g, p) for g, p in donors if g.body.shape == shape]
    if sensors is not None:
        body = Body.build(shape, sensors)
    else:
        body = same[0][0].body if same else Body.build(shape, "paper")
    if isinstance(partition, str):
        partition = Partition.parse(partition, shape)
    elif partition is None:
        partition = same[0][1] if same else Partition.parse("paper", shape)
    if len(partition.modules) < 2:
        raise bad("receiver-partition", partition.grid_string(), "need at least two modules")
    return body, partition


def paper_takes(
    receiver: Partition, donors: Sequence[tuple[Genome, Partition]]
) -> dict[str, Take]:
    """The paper's homogeneous reassembly: every module but the last from donor 1, the last
    from donor 2; both donors must have the receiver's shape and partition."""
    if len(donors) != 2:
        raise bad("donors", len(donors), "the paper's reassembly takes two donors")
    for i, (donor, partition) in enumerate(donors):
        if donor.body.shape != receiver.shape or partition != receiver:
            raise bad(
                f"donor{i + 1}", donor.body.shape.grid_string(),
                "shape or partition differs from the receiver's; say which module comes from "
                "where (--take)",
            )
    (first, first_partition), (second, second_partition) = donors
    *front, last = receiver.modules
    takes = {m: Take(first, first_partition, m) for m in front}
    takes[last] = Take(second, second_partition, last)
    return takes


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
    """Translation that puts the donor's bounding-box corner on the receiver's
    (docs/decisions.md, "Reassembly")."""
    return (
        min(x for x, _ in receiver) - min(x for x, _ in donor),
        min(y for _, y in receiver) - min(y for _, y in donor),
    )


__all__ = [
    "Reassembly",
    "Take",
    "paper_takes",
    "reassemble",
    "receiver_for",
]
