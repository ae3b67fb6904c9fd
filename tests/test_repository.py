"""The repository names no package-registry host: mirrors and indexes come from the
machine's own configuration (e.g. scripts/chroot/debian_mirror.sh reads apt's), so a clone
works behind any mirror and no file points a tool at a host the project cannot reach."""

import re
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

# Written as labels, so this file does not name the hosts it looks for.
REGISTRY_HOSTS = tuple(".".join(labels) for labels in (
    ("deb", "debian", "org"), ("security", "debian", "org"), ("ftp", "debian", "org"),
    ("archive", "ubuntu", "com"), ("security", "ubuntu", "com"),
    ("pypi", "org"), ("pypi", "python", "org"), ("files", "pythonhosted", "org"),
    ("registry", "npmjs", "org"), ("registry", "yarnpkg", "com"),
    ("crates", "io"), ("rubygems", "org"), ("proxy", "golang", "org"),
    ("repo1", "maven", "org"), ("repo", "maven", "apache", "org"),
    ("conda", "anaconda", "org"), ("repo", "anaconda", "com"),
))
PATTERN = re.compile("|".join(re.escape(host) for host in REGISTRY_HOSTS).encode(), re.IGNORECASE)


def registry_hosts_in(data):
    """(line number, host) of every registry host name in ``data`` (bytes)."""
    return [(data.count(b"\n", 0, match.start()) + 1, match.group().decode().lower())
            for match in PATTERN.finditer(data)]


def tracked_files():
    if shutil.which("git") is None or not (REPO / ".git").exists():
        pytest.skip("not a git checkout: no list of tracked files")
    listed = subprocess.run(["git", "ls-files", "-z"], cwd=REPO, capture_output=True, check=True)
    return [REPO / name.decode() for name in listed.stdout.split(b"\0") if name]


def test_the_pattern_finds_a_host_in_a_url():
    url = f"deb http://{REGISTRY_HOSTS[0]}/debian sid main\n".upper().encode()
    assert registry_hosts_in(b"first line\n" + url) == [(2, REGISTRY_HOSTS[0])]
    assert registry_hosts_in(b"http://mirror.example/debian") == []


def test_no_tracked_file_names_a_package_registry_host():
    files = tracked_files()
    assert any(path.name == "README.md" for path in files)
    found = [f"{path.relative_to(REPO)}:{line}: {host}"
             for path in files if path.is_file()
             for line, host in registry_hosts_in(path.read_bytes())]
    assert not found, "package-registry host names in tracked files:\n" + "\n".join(found)


def test_the_core_package_says_its_licence_and_authors_as_the_manifest_does():
    """Issue 27 item 16: one version (gencoords.__version__, which pyproject.toml reads and
    the extension's manifest repeats), the repository's licence, the authors."""
    import importlib.metadata
    import tomllib

    import gencoords

    pyproject = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))
    manifest = tomllib.loads((REPO / "blender_manifest.toml").read_text(encoding="utf-8"))
    project = pyproject["project"]
    assert gencoords.__version__ == manifest["version"]  # the rest: test_layout's one-version test
    licence = (REPO / "LICENSE").read_text(encoding="utf-8")
    assert "GNU GENERAL PUBLIC LICENSE" in licence and "Version 3" in licence
    assert manifest["license"] == [f"SPDX:{project['license']}"] and project["license"] == "GPL-3.0-or-later"
    assert project["license-files"] == ["LICENSE"]
    assert [author["name"] for author in project["authors"]] == [manifest["maintainer"]]
    minor = int(project["requires-python"].removeprefix(">=3."))
    assert {f"Programming Language :: Python :: 3.{v}" for v in range(minor, 15)} <= set(project["classifiers"])
    assert "urls" not in project or not registry_hosts_in(str(project["urls"]).encode())
    installed = importlib.metadata.metadata("gencoords")
    assert installed.get("License-Expression") == project["license"]


def test_scripts_read_kind_ids_from_the_kind_table():
    """Issue 27 item 20: scripts name kinds through the core's constants (KIND_TABLE's
    names, gencoords.surfaces.named, Green's), never as string literals."""
    import ast

    import gencoords
    from gencoords.construction.green import GREEN
    from gencoords.surfaces.named import HARMONIC

    spellings = {kind.name for kind in gencoords.KIND_TABLE} | {GREEN, HARMONIC}
    spellings |= {name.upper() for name in spellings}
    found = [f"{path.relative_to(REPO)}:{node.lineno} {node.value!r}"
             for path in sorted((REPO / "scripts").rglob("*.py"))
             for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
             if isinstance(node, ast.Constant) and node.value in spellings]
    assert not found


def test_the_readme_stays_short_and_every_link_in_it_and_the_docs_resolves():
    """Issue 37 item 13: the README is the newcomer's page (at most 250 lines: figures and
    lore live in docs/), and no relative link of it or of docs/ points at nothing."""
    readme = REPO / "README.md"
    assert len(readme.read_text(encoding="utf-8").splitlines()) <= 250
    broken = []
    for page in [readme, *sorted((REPO / "docs").glob("*.md"))]:
        for target in re.findall(r"\]\(([^)#\s]+)", page.read_text(encoding="utf-8")):
            if "://" not in target and not (page.parent / target).exists():
                broken.append(f"{page.relative_to(REPO)} -> {target}")
    assert not broken, broken
