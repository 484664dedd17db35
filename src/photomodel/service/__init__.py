"""The cell service: a resident photomodel that a cell controller calls over HTTP, or a PLC
over OPC UA (``photomodel serve``; contract in docs/contracts.md)."""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_app": ["create_app"],
        "_audit": ["AUDIT_ACTIONS", "AuditLog", "read_audit"],
        "_auth": ["TokenBook", "read_tokens"],
        "_certs": ["CertFiles", "make_certs"],
        "_cell": ["CellService", "Conflict", "NotFound", "ServiceConfig", "Unavailable",
                  "exposure_warning", "read_token"],
        "_opcua": ["OpcUaFace", "OpcUaThread", "run_opcua_in_thread"],
        "_register": ["register_from_camera"],
        "_ros": ["pose_stamped"],
        "_server": ["ServiceThread", "TlsFiles", "is_loopback", "serve"],
        "_source": ["CameraSource", "SourceError", "StereoGrab", "open_source",
                    "parse_source_spec"],
    },
)

__all__ = ["AUDIT_ACTIONS", "AuditLog", "CameraSource", "CellService", "CertFiles", "Conflict",
           "NotFound", "OpcUaFace", "OpcUaThread", "ServiceConfig", "ServiceThread",
           "SourceError", "StereoGrab", "TlsFiles", "TokenBook", "Unavailable", "create_app",
           "exposure_warning", "is_loopback", "make_certs", "open_source", "parse_source_spec",
           "pose_stamped", "read_audit", "read_token", "read_tokens", "register_from_camera",
           "run_opcua_in_thread", "serve"]
