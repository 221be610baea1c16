"""The registry of studies: the CLI's commands and the report's study options come from the
studies' own subpackages, and a new study is one subpackage (its ``__init__`` declaring
its command and report part): a planted one gets a command and a report option, and its
folders reach its ``gather`` without editing the CLI or the report."""

from __future__ import annotations

import importlib
import sys

import pytest

import volcaustics.reports.studies as studies_package
from volcaustics.reports.cli import TOOLS, build_parser, commands
from volcaustics.reports.studies import registry

NEW_STUDY = '''
from volcaustics.reports.studies.study import Gathered, ReportInput, Study

STUDIES = (Study("planted", "{package}.command", order=99, report=ReportInput(
    "--planted", "planted_rows", "DIR", "a planted study's folders", "{package}:gather", repeatable=True,
    section="{package}:section")),)
SEEN = []


def gather(values, scenes):
    SEEN.append((list(values), list(scenes)))
    return Gathered(tuple({{"folder": v}} for v in values))


def section(rows, media):
    return "<section id='planted'>" + "".join(f"<p>{{r['folder']}}</p>" for r in rows) + "</section>"
'''
COMMAND = '''
def register(sub):
    sub.add_parser("planted", help="a planted study").set_defaults(func=run)


def run(args):
    print("planted ran")
    return 0
'''


@pytest.fixture
def fresh_registry():
    registry.studies.cache_clear()
    yield
    registry.studies.cache_clear()


def test_the_built_in_studies_their_commands_and_report_parts(fresh_registry):
    names = [s.name for s in registry.studies()]
    assert names == ["compare", "animate", "sweep", "frames", "gate"]
    assert [s.report.option for s in registry.reported()] == ["--compare", "--animation", "--sweep", "--frames"]
    assert commands() == (*(f"volcaustics.reports.cli.{t}" for t in TOOLS),
                          *(f"volcaustics.reports.cli.{n}" for n in names), "volcaustics.reports.cli.report")
    for study in registry.studies():
        module = importlib.import_module(study.command)
        assert callable(module.register) and callable(module.run)
    for study in registry.reported():
        assert callable(registry.resolve(study.report.gather))


def test_a_new_study_is_one_subpackage(fresh_registry, tmp_path, monkeypatch, capsys):
    """Planted beside the built-ins (a folder on the studies package's path, holding its
    command module too): listed, its command runs, its option is in `report --help`, its
    values are gathered into its field; the CLI's and the report's code untouched."""
    from volcaustics.reports.presenting.report.report_run import gather_studies

    folder = tmp_path / "planted_study"
    folder.mkdir()
    (folder / "__init__.py").write_text(NEW_STUDY.format(package="volcaustics.reports.studies.planted_study"))
    (folder / "command.py").write_text(COMMAND)
    monkeypatch.setattr(studies_package, "__path__", [*studies_package.__path__, str(tmp_path)])
    monkeypatch.delitem(sys.modules, "volcaustics.reports.studies.planted_study", raising=False)
    assert registry.studies()[-1].name == "planted"
    monkeypatch.delitem(sys.modules, "volcaustics.reports.studies.planted_study.command", raising=False)
    parser = build_parser()
    assert parser.parse_args(["planted"]).func(None) == 0 and "planted ran" in capsys.readouterr().out
    assert "--planted" in parser._subparsers._group_actions[0].choices["report"].format_help()
    gathered = gather_studies({"planted": ["a", "b"], "animate": []}, ["sphere1"])
    assert list(gathered) == ["planted_rows"] and gathered["planted_rows"].document == ({"folder": "a"},
                                                                                       {"folder": "b"})
    planted = sys.modules["volcaustics.reports.studies.planted_study"]
    assert planted.SEEN == [(["a", "b"], ["sphere1"])]
    # its rows kept in the report's document (extra: through summary.json and back) and its section on the page
    from volcaustics.reports.measuring.results.tables import plain
    from volcaustics.reports.presenting.page.html import render_page
    from volcaustics.reports.presenting.page.report_document import GateSummary, ReportDocument

    document = ReportDocument(
        kind="accuracy report", created="today", params={}, seeds=2, reference_settings={}, measurement={},
        budgets="budgets.toml", baseline=None, gate=GateSummary(None, 0, 0, (), ()), scales={}, exposure_rule="",
        scenes=(), sweep=None, gl_renderers=(), code_version="c", versions={}, seconds={},
        extra={"planted_rows": gathered["planted_rows"].document})
    stored = plain(document.to_json())
    assert stored["planted_rows"] == [{"folder": "a"}, {"folder": "b"}]
    page = render_page(ReportDocument.from_json(stored), {}, {})
    assert "<section id='planted'><p>a</p><p>b</p></section>" in page
    with pytest.raises(ValueError, match="no reported study named nowhere"):
        gather_studies({"nowhere": ["x"]}, [])


def test_two_studies_of_one_name_are_refused(fresh_registry, tmp_path, monkeypatch):
    """The negative control: a planted study named as a built-in one."""
    folder = tmp_path / "twice_study"
    folder.mkdir()
    (folder / "__init__.py").write_text(
        'from volcaustics.reports.studies.study import Study\n'
        'STUDIES = (Study("sweep", "volcaustics.reports.cli.sweep", order=1),)\n')
    monkeypatch.setattr(studies_package, "__path__", [*studies_package.__path__, str(tmp_path)])
    monkeypatch.delitem(sys.modules, "volcaustics.reports.studies.twice_study", raising=False)
    with pytest.raises(ValueError, match="studies declared twice: sweep"):
        registry.studies()


def test_a_report_option_or_field_taken_is_refused(fresh_registry, tmp_path, monkeypatch):
    """A planted study with the sweep's report option, then one with a field the report's
    document has of its own (`gate`): refused, not silently replacing it."""
    from volcaustics.reports.presenting.report.report_run import gather_studies

    folder = tmp_path / "clash_study"
    folder.mkdir()
    init = folder / "__init__.py"
    monkeypatch.setattr(studies_package, "__path__", [*studies_package.__path__, str(tmp_path)])
    for option, field, error in (("--sweep", "clash", "report options declared twice: --sweep"),
                                 ("--clash", "gate", "study fields gate: the report's document has such fields")):
        init.write_text('from volcaustics.reports.studies.study import ReportInput, Study\n'
                        f'STUDIES = (Study("clash", "volcaustics.reports.cli.sweep", order=98, report=ReportInput('
                        f'"{option}", "{field}", "DIR", "h", "x:y")),)\n')
        monkeypatch.delitem(sys.modules, "volcaustics.reports.studies.clash_study", raising=False)
        registry.studies.cache_clear()
        with pytest.raises(ValueError, match=error):
            registry.studies()
            gather_studies({}, [])
