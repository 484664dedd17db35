"""Locate a garment with a photomodel cell service (Python standard library only).

usage: python locate_client.py URL MODEL RIGHT LEFT [SEED]   (token: $PHOTOMODEL_TOKEN)
"""

from __future__ import annotations

import http.client
import json
import os
import sys
import uuid
from urllib.parse import urlsplit


def locate(url: str, model: str, right: bytes, left: bytes, seed: str | None = None) -> dict:
    """POST /locate (multipart: files right, left; fields model, seed) -> the JSON answer;
    RuntimeError("error 404: ...") when the service refuses (its JSON's "error")."""
    b = uuid.uuid4().hex
    fields = [("model", "", model.encode())] + ([("seed", "", str(seed).encode())] if seed else [])
    files = [("right", '; filename="right"', right), ("left", '; filename="left"', left)]
    body = b"".join(f'--{b}\r\nContent-Disposition: form-data; name="{name}"{f}\r\n\r\n'.encode()
                    + data + b"\r\n" for name, f, data in fields + files) + f"--{b}--\r\n".encode()
    headers = {"Content-Type": f"multipart/form-data; boundary={b}"}
    if token := os.environ.get("PHOTOMODEL_TOKEN"):
        headers["Authorization"] = f"Bearer {token}"
    u = urlsplit(url)
    https = u.scheme == "https"
    connection = (http.client.HTTPSConnection if https else http.client.HTTPConnection)(
        u.netloc, timeout=300)
    try:
        connection.request("POST", u.path.rstrip("/") + "/locate", body, headers)
        response = connection.getresponse()
        answer = json.load(response)
    finally:
        connection.close()
    if response.status >= 400:
        raise RuntimeError(f"error {response.status}: {answer.get('error')}")
    return answer


if __name__ == "__main__":
    if len(sys.argv) not in (5, 6):
        sys.exit(__doc__.strip())
    url, model, right, left, *seed = sys.argv[1:]
    try:
        with open(right, "rb") as r, open(left, "rb") as lf:
            a = locate(url, model, r.read(), lf.read(), *seed)
    except RuntimeError as err:            # 4xx, 5xx: the service says why
        sys.exit(str(err))
    except (OSError, ValueError) as err:   # no service there, a file missing, not JSON
        sys.exit(f"error: {err}")
    x, y, z = (round(v, 1) for v in a["position_mm"])
    score = None if a["score"] is None else round(a["score"], 3)
    print(f"found={a['found']} position_mm=[{x}, {y}, {z}] theta_deg={a['theta_deg']:.2f} "
          f"score={score} id={a['id']}")
