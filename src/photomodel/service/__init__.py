"""The cell service: a resident photomodel that a cell controller calls over HTTP, or a PLC
over OPC UA (``photomodel serve``; contract in docs/contracts.md)."""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_app": ["create_app"],
        "_cell": ["CellService", "Conflict", "NotFound", "ServiceConfig", "Unavailable",
                  "read_token"],
        "_opcua": ["OpcUaFace", "OpcUaThread", "run_opcua_in_thread"],
        "_ros": ["pose_stamped"],
        "_server": ["ServiceThread", "serve"],
        "_source": ["CameraSource", "SourceError", "StereoGrab", "open_source"],
    },
)

__all__ = ["CameraSource", "CellService", "Conflict", "NotFound", "OpcUaFace", "OpcUaThread",
           "ServiceConfig", "ServiceThread", "SourceError", "StereoGrab", "Unavailable",
           "create_app", "open_source", "pose_stamped", "read_token", "run_opcua_in_thread",
           "serve"]
