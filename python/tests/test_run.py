"""Running scripts: printed output, values out, params in, errors as FeltError."""

import subprocess

import pytest

import felt

VALUES = """
int n = 7 / 2;
float third = 1.0 / 3.0;
bool yes = 2 > 1;
string word = "felt" + "!";
vector v = (1, 2, 3) * 0.5;
matrix m = ((1, 2, 3), (4, 5, 6), (7, 8, 10));
float[] squares = {1.0, 4.0, 9.0};
print(n, third, yes, word, v);
"""


def test_run_returns_what_the_script_printed(session):
    out = session.run(VALUES)
    assert out == "3 0.3333333333333333 true felt! (0.5, 1.0, 1.5)\n"
    assert session.output == out


def test_globals_come_back_as_python_values(session):
    session.run(VALUES)
    assert session.get("n") == 3  # C division, truncated
    assert session.get("third") == 1.0 / 3.0
    assert session.get("yes") is True
    assert session.get("word") == "felt!"
    assert session.get("v") == (0.5, 1.0, 1.5)
    assert session.get("m") == ((1, 2, 3), (4, 5, 6), (7, 8, 10))
    assert session.get("squares") == [1.0, 4.0, 9.0]
    with pytest.raises(KeyError):
        session.get("missing")


def test_output_matches_the_cli(session, felt_cli, tmp_path):
    script = tmp_path / "values.felt"
    script.write_text(VALUES)
    cli = subprocess.run([felt_cli, "run", str(script)], capture_output=True, text=True)
    assert cli.returncode == 0, cli.stderr
    assert session.run_file(script) == cli.stdout


PARAMS = """
param int count = 1;
param float scale = 1.0;
param bool loud = false;
param string label = "none";
param vector offset = (0, 0, 0);
print(count, scale, loud, label, offset);
"""


def test_params_of_every_type(session):
    params = {"count": -12, "scale": 0.1, "loud": True, "label": "a b", "offset": (1.5, -2, 1e-7)}
    session.run(PARAMS, params=params)
    assert session.get("count") == -12
    assert session.get("scale") == 0.1  # the exact double, through the text of --set
    assert session.get("loud") is True
    assert session.get("label") == "a b"
    assert session.get("offset") == (1.5, -2.0, 1e-7)


def test_params_match_the_cli(session, felt_cli, tmp_path):
    script = tmp_path / "params.felt"
    script.write_text(PARAMS)
    sets = ["count=5", "scale=2.5", "loud=true", "label=smoke", "offset=(1, 2, 3)"]
    args = [felt_cli, "run", str(script)]
    for s in sets:
        args += ["--set", s]
    cli = subprocess.run(args, capture_output=True, text=True)
    assert cli.returncode == 0, cli.stderr
    params = {"count": 5, "scale": 2.5, "loud": True, "label": "smoke", "offset": [1, 2, 3]}
    assert session.run_file(script, params=params) == cli.stdout


def test_a_param_of_the_wrong_type_is_a_python_type_error(session):
    with pytest.raises(TypeError):
        session.run(PARAMS, params={"count": object()})


def test_an_unknown_param_is_the_clis_diagnostic(session):
    with pytest.raises(felt.FeltError) as raised:
        session.run(PARAMS, params={"cout": 3})
    assert "did you mean `count`?" in str(raised.value)


def test_errors_carry_the_cli_report_and_diagnostics(session, felt_cli, tmp_path):
    script = tmp_path / "bad.felt"
    script.write_text("float a = 1;\nfloat b = a + nope;\n")
    with pytest.raises(felt.FeltError) as raised:
        session.run_file(script)
    cli = subprocess.run([felt_cli, "run", str(script)], capture_output=True, text=True)
    assert cli.returncode != 0
    assert str(raised.value) == cli.stderr.rstrip()
    [d] = raised.value.diagnostics
    assert (d.severity, d.line, d.column) == ("error", 2, 15)
    assert d.file == str(script)
    assert d.source_line == "float b = a + nope;"
    assert "nope" in d.message


def test_check_returns_diagnostics_without_running(session):
    diags = session.check("print(1);\nint a = \"x\";\n")
    assert [(d.severity, d.line) for d in diags] == [("error", 2)]
    assert session.check("print(1);") == []
    # Nothing ran: check does not make a latest run.
    with pytest.raises(ValueError):
        session.get("a")


def test_a_runtime_error_raises_and_keeps_earlier_output(session):
    with pytest.raises(felt.FeltError) as raised:
        session.run('print("before");\nint z = 0;\nint q = 1 / z;\n')
    assert session.output == "before\n"
    assert raised.value.diagnostics[-1].line == 3


def test_each_run_starts_fresh(session):
    session.run("float a = 1;")
    # A second run declares `a` again without a redeclaration error.
    session.run("float a = 2;")
    assert session.get("a") == 2.0


def test_a_small_memory_budget_refuses_a_large_cache():
    small = felt.Session(memory_limit=1 << 20)
    with pytest.raises(felt.FeltError) as raised:
        small.run("domain d((0,0,0), (1,1,1), (0,0,0), 0.0078125);\nscalarcache c(d);\n")
    # 128³ cells of 4 bytes are 8 MiB: refused at the domain, as docs/language.md says.
    [d] = raised.value.diagnostics
    assert "8.0 MiB" in d.message and "memory budget of 1.0 MiB" in d.message
    assert d.line == 1
    # The same script fits the default budget: the limit is this session's own.
    felt.Session().run("domain d((0,0,0), (1,1,1), (0,0,0), 0.0078125);\nscalarcache c(d);\n")
