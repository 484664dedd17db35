"""Locate a garment with a photomodel cell service (Python standard library only).

usage: python locate_client.py URL MODEL RIGHT LEFT [SEED] [--raw]   (token: $PHOTOMODEL_TOKEN)

An https:// URL is checked against the system's CAs, or the CA file in $PHOTOMODEL_CA (the
ca.pem that ``photomodel certs`` writes).

--raw sends the two views as raw BGR pixels (one application/octet-stream body, no image
encoding), as a client holding frames in memory would; it reads the files with OpenCV here.
"""

from __future__ import annotations

import http.client
import json
import os
import ssl
import sys
import uuid
from urllib.parse import urlencode, urlsplit


def locate(url: str, model: str, right: bytes, left: bytes, seed: str | None = None) -> dict:
    """POST /locate (multipart: files right, left; fields model, seed) -> the JSON answer;
    RuntimeError("error 404: ...") when the service refuses (its JSON's "error")."""
    b = uuid.uuid4().hex
    fields = [("model", "", model.encode())] + ([("seed", "", str(seed).encode())] if seed else [])
    files = [("right", '; filename="right"', right), ("left", '; filename="left"', left)]
    body = b"".join(f'--{b}\r\nContent-Disposition: form-data; name="{name}"{f}\r\n\r\n'.encode()
                    + data + b"\r\n" for name, f, data in fields + files) + f"--{b}--\r\n".encode()
    return _post(url, "/locate", body, f"multipart/form-data; boundary={b}")


def locate_raw(url: str, model: str, right: bytes, left: bytes, width: int, height: int,
               pixel_format: str = "bgr8", seed: str | None = None) -> dict:
    """POST /locate with the two views as raw pixels (``width`` x ``height``, ``pixel_format``
    bgr8, rgb8 or mono8, rows top to bottom) in one application/octet-stream body, right
    first, the fields in the query: no image encoding, no multipart. Answers as locate."""
    query = {"model": model, "width": width, "height": height, "pixel_format": pixel_format}
    if seed:
        query["seed"] = seed
    return _post(url, "/locate?" + urlencode(query), right + left, "application/octet-stream")


def _post(url: str, route: str, body: bytes, content_type: str) -> dict:
    headers = {"Content-Type": content_type}
    if token := os.environ.get("PHOTOMODEL_TOKEN"):
        headers["Authorization"] = f"Bearer {token}"
    u = urlsplit(url)
    https = u.scheme == "https"
    if https:
        context = ssl.create_default_context(cafile=os.environ.get("PHOTOMODEL_CA") or None)
        connection: http.client.HTTPConnection = http.client.HTTPSConnection(
            u.netloc, timeout=300, context=context)
    else:
        connection = http.client.HTTPConnection(u.netloc, timeout=300)
    try:
        connection.request("POST", u.path.rstrip("/") + route, body, headers)
        response = connection.getresponse()
        answer = json.load(response)
    finally:
        connection.close()
    if response.status >= 400:
        raise RuntimeError(f"error {response.status}: {answer.get('error')}")
    return answer


if __name__ == "__main__":
    raw = "--raw" in sys.argv[1:]
    args = [a for a in sys.argv[1:] if a != "--raw"]
    if len(args) not in (4, 5):
        sys.exit(__doc__.strip())
    url, model, right, left, *seed = args
    try:
        if raw:            # frames a camera SDK would hand over in memory
            import cv2  # only to read the files here

            views = [cv2.imread(path, cv2.IMREAD_COLOR) for path in (right, left)]
            if any(v is None for v in views):
                raise OSError(f"cannot read {right} or {left} as images")
            h, w = views[0].shape[:2]
            a = locate_raw(url, model, views[0].tobytes(), views[1].tobytes(), w, h,
                           "bgr8", *seed)
        else:
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
