"""Locate a garment through the cell service's OPC UA face, as a PLC would (needs asyncua).

usage: python opcua_client.py [--endpoint opc.tcp://127.0.0.1:4840/photomodel/] [--model No.3]
                              [--certs DIR] [--user LABEL]
(a service started with --token-file: the token in $PHOTOMODEL_TOKEN, user LABEL, default
'photomodel'; one started with --tls-cert: --certs DIR, the folder `photomodel certs` wrote,
for Basic256Sha256 SignAndEncrypt with DIR/client.pem and DIR/client.key)

It calls PhotomodelVision.Locate(model), then reads the result variables and the state in
one Read and prints them; a Bad answer is one line on stderr (the status and the service's
LastCallText) and exit status 1.
"""

from __future__ import annotations

import argparse
import asyncio
import logging
import os
import sys

from asyncua import Client, ua

NAMESPACE = "urn:photomodel:cell"
VARIABLES = ["Found", "Model", "PositionMm", "QuatWxyz", "ThetaDeg", "Score", "Timestamp",
             "ResultId", "State", "StateNumber", "ErrorText"]


async def locate(endpoint: str, model: str, timeout_s: float = 30.0, certs: str | None = None,
                 user: str = "photomodel") -> dict:
    """Call Locate(model) and read the result variables -> {name: value} plus "outputs";
    ua.UaStatusCodeError (with the service's text as ``text``) on a Bad answer."""
    client = Client(endpoint, timeout=timeout_s)     # a search takes up to seconds
    if token := os.environ.get("PHOTOMODEL_TOKEN"):
        client.set_user(user)
        client.set_password(token)
    if certs is not None:
        from asyncua.crypto.security_policies import SecurityPolicyBasic256Sha256
        from asyncua.crypto.uacrypto import CertProperties

        client.application_uri = "urn:photomodel:client"    # the URI client.pem names
        await client.set_security(                 # client.key is PEM: asyncua guesses DER
            SecurityPolicyBasic256Sha256, f"{certs}/client.pem",
            CertProperties(f"{certs}/client.key", extension="pem"),
            server_certificate=f"{certs}/server.pem", mode=ua.MessageSecurityMode.SignAndEncrypt)
    async with client:
        ns = await client.get_namespace_index(NAMESPACE)

        def node(name: str):
            return client.get_node(ua.NodeId(f"PhotomodelVision.{name}", ns))

        vision = client.get_node(ua.NodeId("PhotomodelVision", ns))
        try:
            outputs = await vision.call_method(ua.NodeId("PhotomodelVision.Locate", ns), model)
        except ua.UaStatusCodeError as err:
            err.text = await node("LastCallText").read_value()
            raise
        values = await client.read_values([node(name) for name in VARIABLES])
    return {"outputs": outputs, **dict(zip(VARIABLES, values, strict=True))}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--endpoint", default="opc.tcp://127.0.0.1:4840/photomodel/")
    parser.add_argument("--model", default="No.3")
    parser.add_argument("--timeout-s", type=float, default=30.0)
    parser.add_argument("--certs", default=None, help="folder of photomodel certs' files")
    parser.add_argument("--user", default="photomodel", help="the token's label")
    args = parser.parse_args()
    logging.getLogger("asyncua").setLevel(logging.ERROR)   # its notes on session timeouts
    try:
        r = asyncio.run(locate(args.endpoint, args.model, args.timeout_s, args.certs, args.user))
    except ua.UaStatusCodeError as err:
        name = ua.status_codes.get_name_and_doc(err.code)[0]
        print(f"{name}: {getattr(err, 'text', '')}", file=sys.stderr)
        return 1
    except (TimeoutError, OSError) as err:
        print(f"cannot reach {args.endpoint}: {err or type(err).__name__}", file=sys.stderr)
        return 1
    except ua.UaError as err:          # e.g. a secure-only service asked without --certs
        print(f"{args.endpoint}: {err}", file=sys.stderr)
        return 1
    found, result_id = r["outputs"]
    x, y, z = r["PositionMm"]
    print(f"Locate({args.model!r}) -> found={found} result_id={result_id}")
    print(f"model={r['Model']} position_mm=[{x:.1f}, {y:.1f}, {z:.1f}] quat_wxyz="
          f"[{', '.join(f'{q:.4f}' for q in r['QuatWxyz'])}] theta_deg={r['ThetaDeg']:.2f} "
          f"score={r['Score']:.3f} frame={r['Timestamp'].isoformat()}")
    print(f"state={r['State']} ({r['StateNumber']}) error_text={r['ErrorText']!r}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
