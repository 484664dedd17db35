"""The cell service: a resident photomodel that a cell controller calls over HTTP, or a PLC
over OPC UA (``photomodel serve``; contract in docs/contracts.md)."""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_app": ["create_app"],
        "_audit": ["AuditLog", "read_audit"],
        "_auth": ["TokenBook", "read_tokens"],
        "_certs": ["make_certs"],
        "_cell": ["CellService", "Conflict", "NotFound", "ServiceConfig", "Unavailable",
                  "read_token"],
        "_opcua": ["OpcUaFace", "OpcUaThread", "run_opcua_in_thread"],
        "_ros": ["pose_stamped"],
        "_server": ["ServiceThread", "TlsFiles", "serve"],
        "_source": ["CameraSource", "SourceError", "StereoGrab", "open_source"],
    },
)

__all__ = ["AuditLog", "CameraSource", "CellService", "Conflict", "NotFound", "OpcUaFace",
           "OpcUaThread", "ServiceConfig", "ServiceThread", "SourceError", "StereoGrab",
           "TlsFiles", "TokenBook", "Unavailable", "create_app", "make_certs", "open_source",
           "pose_stamped", "read_audit", "read_token", "read_tokens", "run_opcua_in_thread",
           "serve"]
