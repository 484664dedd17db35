"""A service killed (SIGKILL) during registrations, 20 times: its audit trail keeps every line
it wrote, each one parseable, and the library stays readable."""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import time

import pytest

from photomodel.library import ModelLibrary
from photomodel.service._audit import read_audit

_WORKER = """
import sys
from pathlib import Path
from photomodel.service import CellService, ServiceConfig
stereo, camera, library, photo, background = sys.argv[1:6]
cell = CellService(ServiceConfig(stereo=Path(stereo), models=Path(library),
                                 camera=Path(camera)))
cell.warm()
photo, background = Path(photo).read_bytes(), Path(background).read_bytes()
print("ready", flush=True)
k = 0
while True:
    cell.register(f"kill-{k % 3}", photo, background, replace=True)
    k += 1
"""


@pytest.mark.slow
def test_twenty_kills_during_registrations_leave_a_whole_audit_trail(cell_data, tmp_path
                                                                       ) -> None:
    library = tmp_path / "library"
    ModelLibrary(library, create=True)
    model_dir = cell_data.dataset / "models" / "No.5"
    argv = [sys.executable, "-c", _WORKER, str(cell_data.stereo), str(cell_data.camera),
            str(library), str(model_dir / "photo.bmp"), str(model_dir / "background.bmp")]
    audit = library / "audit" / "audit.jsonl"
    rng = random.Random(49)
    counts = []
    for _ in range(20):
        errors = (tmp_path / "worker.err").open("w")
        worker = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=errors, text=True)
        assert worker.stdout is not None
        if worker.stdout.readline().strip() != "ready":
            worker.wait(timeout=30)
            pytest.fail("the worker did not start: "
                        f"{(tmp_path / 'worker.err').read_text()[-2000:]}")
        time.sleep(rng.uniform(0.2, 1.5))         # a registration takes about 0.5 s
        os.kill(worker.pid, signal.SIGKILL)
        worker.wait(timeout=30)
        errors.close()
        lines = audit.read_bytes().splitlines() if audit.exists() else []
        counts.append(len(lines))
        for line in lines[:-1]:
            json.loads(line)                     # every whole line parses
    events = list(read_audit(audit))
    assert len(events) >= 10 and counts == sorted(counts)
    assert {e["action"] for e in events} <= {"register", "replace"}
    assert all(len(e["sha256"]) == 64 for e in events)
    for line in audit.read_bytes().splitlines():
        json.loads(line)
    scan = ModelLibrary(library).scan()
    assert len(scan.entries) >= 1
