"""CI must run exactly the test command the README gives."""
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _commands(text: str) -> list[str]:
    return [c.strip() for c in re.findall(r"```bash\n(.*?)```", text, flags=re.S)]


def test_ci_runs_the_readme_test_command():
    readme_cmds = _commands((ROOT / "README.md").read_text())
    assert len(readme_cmds) >= 2
    test_cmd = readme_cmds[1]
    assert "pytest" in test_cmd
    ci_lines = [l.strip() for l in (ROOT / ".ci" / "run").read_text().splitlines()]
    assert test_cmd in ci_lines


MAX_LINES = 200
MAX_LINE_CHARS = 200


def test_the_readme_is_a_front_page():
    """What it is, the two commands, a short generated summary, a table of commands and links: the rest
    lives in docs/ (docs/commands.md, docs/fmus.md, docs/recordings.md, docs/sweeps.md, ...)."""
    lines = (ROOT / "README.md").read_text().splitlines()
    assert len(lines) <= MAX_LINES, f"README.md has {len(lines)} lines; at most {MAX_LINES}"
    long = [n for n, line in enumerate(lines, start=1) if len(line) > MAX_LINE_CHARS]
    assert not long, f"README.md lines over {MAX_LINE_CHARS} characters: {long}"


def test_every_doc_the_readme_links_exists():
    text = (ROOT / "README.md").read_text()
    links = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", text)
    assert links and all((ROOT / link).is_file() for link in links), [l for l in links if not (ROOT / l).is_file()]


def test_a_passing_run_leaves_no_temporary_folders():
    """CI left 1.5 GB in TMPDIR: pytest kept the folders of the last three runs (the FMUs, the installed
    wheel), and four FMUs a child process unpacked stayed in tmpXXXXXXXX/ (the tests that ran those children
    now see their TMPDIR empty: tests/fmu/test_bytecode.py, tests/shipped/test_shipped_fmus.py)."""
    import tomllib

    ini = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["pytest"]["ini_options"]
    assert ini["tmp_path_retention_policy"] == "failed" and int(ini["tmp_path_retention_count"]) <= 1
