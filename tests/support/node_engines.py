"""Engines from the npm registry (node-wot, Node-RED with node-red-contrib-modbus) for the export proofs
(SPEC 11.1), as tests/support/engines.py keeps the Python ones: each installed with npm into a folder of
its own under $MDL_ENGINE_CACHE (default ~/.cache/mdl-engines/), named by the engine, its pinned versions
and the Node.js version, so that a later run (or a later machine given the same cache) reuses it. A
folder is used only once npm and a require() check succeeded (its marker file); an interrupted install is
made again. Several test processes asking at once wait for one another (a file lock).

`python3 tests/support/node_engines.py [NAME...]` installs them ahead of a test run.
Versions (checked with `npm view`, Node.js 20):
- node-wot: @node-wot/core and @node-wot/binding-modbus 0.8.16, the newest 0.8 release.
- Node-RED: node-red 4.1.15 (Node-RED 5 needs Node.js 22.9) with node-red-contrib-modbus 5.23.3 (later
  releases depend on a tarball outside the npm registry).
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run as a script: `support` importable

from support.engines import EngineUnavailable, cache_root, installed  # noqa: E402
from support.mqtt import free_port  # noqa: E402


@dataclass(frozen=True)
class NodeEngine:
    name: str
    packages: tuple[str, ...]  # npm package specifiers, every one pinned
    probe: tuple[str, ...] = ()  # modules require()d to check the install

    def key(self, node_version: str) -> str:
        digest = hashlib.sha256("\n".join((*self.packages, node_version)).encode()).hexdigest()[:12]
        return f"{self.name}-node{node_version.lstrip('v').split('.')[0]}-{digest}"


NODE_WOT = NodeEngine(
    "node-wot",
    ("@node-wot/core@0.8.16", "@node-wot/binding-modbus@0.8.16", "@node-wot/td-tools@0.8.16"),
    probe=("@node-wot/core", "@node-wot/binding-modbus"),
)
NODE_RED = NodeEngine(
    "node-red",
    ("node-red@4.1.15", "node-red-contrib-modbus@5.23.3"),
    probe=("node-red", "node-red-contrib-modbus/package.json"),
)
NODE_ENGINES = {engine.name: engine for engine in (NODE_WOT, NODE_RED)}


def node_version() -> str:
    node = shutil.which("node")
    if node is None or shutil.which("npm") is None:
        raise EngineUnavailable("Node.js and npm are not installed (apt-get install nodejs npm)")
    return subprocess.run([node, "--version"], capture_output=True, text=True, check=True).stdout.strip()


def engine_dir(engine: NodeEngine, *, timeout: float = 1800) -> Path:
    """The folder whose node_modules hold the engine, installed if it is not cached yet."""
    version = node_version()
    root = cache_root()
    root.mkdir(parents=True, exist_ok=True)
    key = engine.key(version)
    final = root / key
    with open(root / f"{key}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if (final / "mdl-engine-ok").is_file():
            return final
        shutil.rmtree(final, ignore_errors=True)
        final.mkdir(parents=True)
        (final / "package.json").write_text('{"name": "mdl-engine", "private": true}\n')
        command = ["npm", "install", "--no-audit", "--no-fund", "--loglevel=error", *engine.packages]
        try:
            proc = subprocess.run(command, cwd=final, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            raise EngineUnavailable(f"npm install {' '.join(engine.packages)} took over {timeout:.0f} s") from None
        if proc.returncode != 0:
            tail = "\n".join((proc.stdout + proc.stderr).strip().splitlines()[-15:])
            raise EngineUnavailable(f"npm install {' '.join(engine.packages)} failed:\n{tail}")
        for module in engine.probe:
            check = subprocess.run(
                ["node", "-e", f"require({module!r})"], cwd=final, capture_output=True, text=True, timeout=120
            )
            if check.returncode != 0:
                raise EngineUnavailable(f"{engine.name} installed but {module} does not load: {check.stderr[-800:]}")
        (final / "mdl-engine-ok").write_text("\n".join(engine.packages) + "\n")
        return final


def require_node_engine(engine: NodeEngine) -> Path:
    """The engine's folder for a test; skipped with the reason when it cannot be installed (a failure in CI)."""
    return installed(engine.name, lambda: engine_dir(engine))


if __name__ == "__main__":
    for name in sys.argv[1:] or list(NODE_ENGINES):
        print(f"{name}: {engine_dir(NODE_ENGINES[name])}")


class NodeRed:
    """Node-RED run headless from the cached install: a user folder holding the flows file and settings
    without the editor or any HTTP endpoint; stopped with SIGINT, killed if it does not stop."""

    def __init__(self, folder: Path, nodes: list[dict], home: Path, level: str = "warn") -> None:
        self.home = home  # the install's folder: engine_dir or require_node_engine of NODE_RED
        self.folder = folder
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "flows.json").write_text(json.dumps(nodes, indent=1), encoding="utf-8")
        (folder / "settings.js").write_text(
            "module.exports = {\n"
            '  flowFile: "flows.json",\n'
            f'  uiPort: {free_port()}, uiHost: "127.0.0.1",\n'
            "  httpAdminRoot: false, httpNodeRoot: false, credentialSecret: false,\n"
            "  telemetry: { enabled: false }, externalModules: { autoInstall: false },\n"
            f'  logging: {{ console: {{ level: "{level}", metrics: false, audit: false }} }}\n'
            "};\n",
            encoding="utf-8",
        )
        self.log = open(folder / "node-red.log", "w")  # noqa: SIM115 - closed in stop()
        red = self.home / "node_modules" / "node-red" / "red.js"
        self.proc = subprocess.Popen(
            ["node", str(red), "--userDir", str(folder), "--settings", str(folder / "settings.js")],
            cwd=folder,
            stdout=self.log,
            stderr=subprocess.STDOUT,
            env={**os.environ, "NODE_RED_ENABLE_PROJECTS": "false"},
        )
        self.pid = self.proc.pid

    def said(self, tail: int = 4000) -> str:
        if not self.log.closed:
            self.log.flush()
        return (self.folder / "node-red.log").read_text(encoding="utf-8", errors="replace")[-tail:]

    def stop(self) -> None:
        if self.log.closed:
            return
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log.close()
