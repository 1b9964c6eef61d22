"""Campaign integrity (issue 23): a hostile or damaged ``campaign.json``, a report written into
its campaign, campaign files whose faults would show only once tasks run, and a scheduler that
cannot be reached. Each is refused up front: one line on stderr, exit code 2, nothing written.
No task runs: the campaign directories are a built-in's ``campaign.json`` written by hand."""

from __future__ import annotations

import json
import socket
from pathlib import Path

import pytest

from somite.campaigns.builtin import builtin
from somite.campaigns.directory import document, prepare
from somite.campaigns.expansion import expand
from somite.campaigns.spec import MAX_NAME, load
from somite.cli import main


def _tree(root: Path) -> dict[str, bytes | None]:
    """Every path under ``root`` (a folder: None), with file contents: what a refusal must
    leave as it was."""
    return {str(p.relative_to(root)): (None if p.is_dir() else p.read_bytes())
            for p in sorted(root.rglob("*")) if not p.is_symlink() or p.exists()}


def _refused(capsys, argv: list[str], field: str, root: Path) -> str:
    """``somite ARGV`` exits 2 with one line naming ``field``, and writes nothing under
    ``root``."""
    before = _tree(root)
    assert main(argv) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert f"error: {field}=" in err, err
    assert _tree(root) == before
    return err


@pytest.fixture(scope="module")
def smoke_doc() -> dict:
    smoke = builtin("smoke")
    return document(smoke, expand(smoke))


@pytest.fixture
def campaign(tmp_path, smoke_doc):
    """A smoke campaign's directory (no task run), two levels below ``tmp_path`` (so that
    ``../../x`` would land in ``tmp_path``), and a function to rewrite its campaign.json."""
    root = tmp_path / "runs" / "smoke"
    prepare(root, smoke_doc, resume=False)

    def damage(change) -> Path:
        doc = json.loads((root / "campaign.json").read_text())
        change(doc)
        (root / "campaign.json").write_text(json.dumps(doc))
        return root

    return root, damage


def _index(doc: dict, task_id: str) -> int:
    return next(i for i, t in enumerate(doc["tasks"]) if t["id"] == task_id)


def _set(task_id: str, key: str, value):
    def change(doc):
        doc["tasks"][_index(doc, task_id)][key] = value
    return change


def _drop(task_id: str, key: str):
    def change(doc):
        del doc["tasks"][_index(doc, task_id)][key]
    return change


def _twice(doc):
    """The fourth task listed again: two tasks of one id."""
    doc["tasks"].insert(4, dict(doc["tasks"][3]))


def _later(doc):
    """A task that needs one listed after it."""
    doc["tasks"][0]["needs"] = [doc["tasks"][-1]["id"]]


def _nested(doc):
    task = dict(doc["tasks"][0], id="rq1/biped-s0/inner", path="rq1/biped-s0/inner")
    doc["tasks"].append(task)


# -- campaign.json, read by `campaign status` and `campaign run --resume` ----------------------

DAMAGE = [
    (_set("rq1/biped-s1", "path", "../../x"), "campaign.json: tasks[1].path"),
    (_set("rq1/biped-s1", "path", "/tmp/somite-x"), "campaign.json: tasks[1].path"),
    (_set("rq1/biped-s1", "path", "rq1/./biped-s1"), "campaign.json: tasks[1].path"),
    (_set("rq1/biped-s1", "path", "rq1//biped-s1"), "campaign.json: tasks[1].path"),
    (_set("rq1/biped-s1", "path", "rq1/elsewhere"), "campaign.json: tasks[1].path"),
    (_set("rq1/biped-s1", "path", "campaign.json"), "campaign.json: tasks[1].path"),
    (_set("rq1/biped-s1", "path", 7), "campaign.json: tasks[1].path"),
    (_set("rq1/biped-s1", "id", "../biped-s1"), "campaign.json: tasks[1].id"),
    (_set("rq1/biped-s1", "id", "biped-s1"), "campaign.json: tasks[1].id"),
    (_drop("rq1/biped-s1", "path"), "campaign.json: tasks[1].path"),
    (_drop("rq1/biped-s1", "needs"), "campaign.json: tasks[1].needs"),
    (_drop("rq1/biped-s1", "options"), "campaign.json: tasks[1].options"),
    (_set("rq1/biped-s1", "needs", "rq1/biped-s0"), "campaign.json: tasks[1].needs"),
    (_set("rq1/biped-s1", "needs", ["rq1/nothing"]), "campaign.json: tasks[1].needs"),
    (_set("rq1/biped-s1", "needs", ["rq1/biped-s1"]), "campaign.json: tasks[1].needs"),
    (_set("rq1/biped-s1", "options", []), "campaign.json: tasks[1].options"),
    (_set("rq1/biped-s1", "kind", "bake"), "campaign.json: tasks[1].kind"),
    (_set("rq1/biped-s1", "experiment", "rq9"), "campaign.json: tasks[1].experiment"),
    (_set("rq1/biped-s1", "colour", "red"), "campaign.json: tasks[1].colour"),
    (_twice, "campaign.json: tasks[4].id"),
    (_later, "campaign.json: tasks[0].needs"),
    (_nested, "campaign.json: tasks[60].path"),
    (lambda doc: doc.update(tasks={}), "campaign.json: tasks"),
    (lambda doc: doc.update(tasks=[3]), "campaign.json: tasks[0]"),
    (lambda doc: doc.pop("name"), "campaign.json: name"),
    (lambda doc: doc["experiments"].update({"../x": {}}), "campaign.json: experiments"),
    (lambda doc: doc["experiments"].update(rq1=[]), "campaign.json: experiments.rq1"),
]


@pytest.mark.parametrize("change, field", DAMAGE)
@pytest.mark.parametrize("command", ["status", "resume"])
def test_a_damaged_campaign_json_is_one_line(tmp_path, capsys, campaign, change, field,
                                             command):
    root, damage = campaign
    damage(change)
    argv = (["campaign", "status", str(root)] if command == "status" else
            ["campaign", "run", "--resume", "--out", str(root), "--quiet"])
    _refused(capsys, argv, field, tmp_path)


def test_the_path_error_says_what_a_path_must_be(tmp_path, capsys, campaign):
    root, damage = campaign
    damage(_set("rq1/biped-s1", "path", "../../x"))
    err = _refused(capsys, ["campaign", "status", str(root)], "campaign.json: tasks[1].path",
                   tmp_path)
    assert "tasks[1].path='../../x': must be a relative path inside the campaign folder" in err
    assert not (tmp_path / "x").exists()


def test_a_symbolic_link_out_of_the_campaign_is_refused(tmp_path, capsys, campaign):
    root, _ = campaign
    outside = tmp_path / "outside"
    outside.mkdir()
    (root / "rq1").symlink_to(outside, target_is_directory=True)
    for argv in (["campaign", "status", str(root)],
                 ["campaign", "run", "--resume", "--out", str(root), "--quiet"]):
        err = _refused(capsys, argv, "campaign.json: tasks[0].path", tmp_path)
        assert "symbolic link" in err
    assert not any(outside.iterdir())


OPTIONS = [
    ("rq1/biped-s0", {"population": 1}, "population"),
    ("rq1/biped-s0", {"colour": "red"}, "colour"),
    ("rq1/biped-s0", {"omega": 10.0, "modules": "worm-halves"}, "modules"),
    ("rq1/biped-s0", {"donors": ["rq1/biped-s1"]}, "donors"),
    ("rq2-homo/biped-s0+s1", {"donors": ["rq1/worm-s0", "rq1/biped-s1"]}, "donors"),
    ("rq2-homo/biped-s0+s1", {"partitions": ["../../x/partition.json"]}, "partitions"),
    ("rq2-homo/biped-s0+s1", {"preset": None}, "preset"),
    ("rq2-homo/biped-s0+s1", {"validation": 0}, "validation"),
    ("rq2-homo/biped-s0+s1", {"receiver_shape": "blob"}, "receiver_shape"),
    ("rq2-homo/biped-s0+s1-reopt", {"start": "rq1/biped-s0"}, "start"),
    ("rq2-homo/biped-s0+s1-reopt", {"validation": None}, "validation"),
    ("rq3-discovery/biped-s0", {"genome": None}, "genome"),
    ("rq3-discovery/biped-s0", {"b_max": 11}, "b_max"),
]


@pytest.mark.parametrize("task_id, changes, key", OPTIONS)
def test_a_task_of_bad_options_is_refused_before_any_runs(tmp_path, capsys, campaign,
                                                          smoke_doc, task_id, changes, key):
    root, damage = campaign

    def change(doc):
        options = doc["tasks"][_index(doc, task_id)]["options"]
        for name, value in changes.items():
            if value is None:
                options.pop(name)
            else:
                options[name] = value

    damage(change)
    field = f"campaign.json: tasks[{_index(smoke_doc, task_id)}].options.{key}"
    _refused(capsys, ["campaign", "run", "--resume", "--out", str(root), "--quiet"], field,
             tmp_path)


# -- somite report --out ------------------------------------------------------------------------

def test_a_report_into_its_campaign_is_refused(tmp_path, capsys, campaign):
    root, _ = campaign
    (root / "rq1" / "biped-s0").mkdir(parents=True)
    link = tmp_path / "link"
    link.symlink_to(root / "rq1" / "biped-s0", target_is_directory=True)
    for out in (root, root / "rq2-homo" / "biped-s0+s1", root / "new", link):
        err = _refused(capsys, ["report", str(root), "--out", str(out), "--quiet"], "out",
                       tmp_path)
        assert "campaign folder" in err
    # A campaign folder in the report's figures/ would be written into too.
    figures = tmp_path / "rep" / "figures"
    figures.parent.mkdir()
    root.rename(figures)
    _refused(capsys, ["report", str(figures), "--out", str(figures.parent), "--quiet"], "out",
             tmp_path)


# -- campaign files: everything checked before anything is written ------------------------------

GRID = "kind = 'evolve'\nshapes = ['biped']\nseeds = 2\n"
LONG = "e" * 300

SPECS = [
    (f"[experiments.{LONG}]\n{GRID}", "experiments"),
    (f"[experiments.a]\n{GRID}variants = {{ {'v' * (MAX_NAME + 1)} = {{}} }}\n",
     "experiments.a.variants"),
    (f"[experiments.a]\n{GRID}variants = {{ v = {{ seed = 3 }} }}\n",
     "experiments.a.variants.v.seed"),
    (f"[experiments.a]\n{GRID}options = {{ shape = 'worm' }}\n", "experiments.a.options.shape"),
    (f"[experiments.a]\n{GRID}options = {{ start = 'x.json' }}\n",
     "experiments.a.options.start"),
    (f"[defaults]\nseed = 4\n[experiments.a]\n{GRID}", "defaults.seed"),
    (f"[experiments.a]\n{GRID}[experiments.b]\nkind = 'reassemble'\ndonors = 'a'\n"
     "reoptimize = { shape = 'worm' }\n", "experiments.b.reoptimize.shape"),
    (f"[experiments.a]\n{GRID}[experiments.b]\nkind = 'reassemble'\ndonors = 'a'\n"
     "reoptimize = { seed = 1 }\n", "experiments.b.reoptimize.seed"),
    (f"[experiments.a]\n{GRID}[experiments.d]\nkind = 'discover'\ngenomes = 'a'\nb_max = 11\n",
     "experiments.d.b_max"),
    (f"[experiments.a]\n{GRID}[experiments.b]\nkind = 'reassemble'\ndonors = 'a'\n"
     "partition = 'worm-parts.json'\n", "experiments.b.partition"),
    (f"[experiments.a]\n{GRID}[experiments.b]\nkind = 'reassemble'\ndonors = 'a'\n"
     "partition = 'missing.json'\n", "experiments.b.partition"),
    (f"[experiments.a]\n{GRID}options = {{ omega = 10.0, modules = 'worm-halves' }}\n",
     "experiments.a.modules"),
    ("[experiments.omega]\nkind = 'evolve'\nshapes = ['worm']\nseeds = 2\n"
     "variants = { 10 = {} }\n[experiments.omega-10]\nkind = 'evolve'\nshapes = ['worm']\n"
     "seeds = 2\n[experiments.r]\nkind = 'reassemble'\ndonors = ['omega-10', 'omega']\n",
     "experiments.r"),
    (f"[experiments.'campaign.json']\n{GRID}", "experiments"),
]


def _worm_partition(folder: Path) -> Path:
    from somite.sim.partition import Partition

    path = folder / "worm-parts.json"
    path.write_text(json.dumps(Partition.preset("paper", "worm").to_dict()))
    return path


@pytest.mark.parametrize("text, field", SPECS)
def test_a_campaign_file_is_checked_before_anything_is_written(tmp_path, capsys, text, field):
    spec = tmp_path / "spec" / "bad.toml"
    spec.parent.mkdir()
    spec.write_text(text)
    _worm_partition(spec.parent)
    err = _refused(capsys, ["campaign", "run", str(spec), "--out", str(tmp_path / "o")], field,
                   tmp_path)
    assert not (tmp_path / "o").exists()
    if field.endswith(".seed") or field.endswith(".shape"):
        assert "seeds decide" in err or "shapes decide" in err or "decides" in err


def test_partition_files_are_read_relative_to_the_campaign_file(tmp_path, monkeypatch):
    spec = tmp_path / "spec" / "mine.toml"
    spec.parent.mkdir()
    parts = _worm_partition(spec.parent)
    spec.write_text("[experiments.a]\nkind = 'evolve'\nshapes = ['worm']\nseeds = 2\n"
                    "options = { omega = 10.0, modules = 'worm-parts.json' }\n"
                    "[experiments.b]\nkind = 'reassemble'\ndonors = 'a'\n"
                    "partition = 'worm-parts.json'\n")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    tasks = {t["id"]: t for t in expand(load(Path("..") / "spec" / "mine.toml"))}
    assert tasks["b/worm-s0+s1"]["options"]["partitions"] == [str(parts.resolve())] * 2
    assert tasks["a/worm-s0"]["options"]["modules"] == str(parts.resolve())


# -- an unreachable scheduler -------------------------------------------------------------------

def test_an_unreachable_scheduler_leaves_nothing_behind(tmp_path, capsys, monkeypatch):
    from somite.campaigns import executor

    monkeypatch.setattr(executor, "CONNECT_TIMEOUT", "1s")
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]  # closed again: nothing listens there
    out = tmp_path / "o"
    argv = ["campaign", "run", "smoke", "--out", str(out), "--scheduler",
            f"tcp://127.0.0.1:{port}", "--quiet"]
    err = _refused(capsys, argv, "scheduler", tmp_path)
    assert "cannot connect" in err
    assert not out.exists()
    # The same again is the same refusal, not "holds campaign 'smoke' already".
    _refused(capsys, argv, "scheduler", tmp_path)
