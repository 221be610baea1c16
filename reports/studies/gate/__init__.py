"""The regression gate: budgets, the regression test against a baseline, the verdict on
one result as a pure function (shared with the report), and what the gate writes."""

from volcaustics.reports.studies.study import Study

STUDIES = (Study("gate", "volcaustics.reports.cli.gate", order=50),)
