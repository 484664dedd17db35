# The subpackage's public names (lazy_loader.attach_stub reads this file; type
# checkers read it as the package's stub). One list: add a name here only.

from ._app import (
    create_app,
)
from ._audit import (
    AUDIT_ACTIONS,
    AuditLog,
    read_audit,
)
from ._auth import (
    TokenBook,
    read_tokens,
)
from ._cell import (
    CellService,
    Conflict,
    NotFound,
    ServiceConfig,
    Unavailable,
    exposure_warning,
    read_token,
)
from ._certs import (
    CertFiles,
    make_certs,
)
from ._opcua import (
    OpcUaFace,
    OpcUaThread,
    run_opcua_in_thread,
)
from ._register import (
    register_from_camera,
)
from ._ros import (
    pose_stamped,
)
from ._server import (
    ServiceThread,
    TlsFiles,
    is_loopback,
    serve,
)
from ._source import (
    CameraSource,
    SourceError,
    StereoGrab,
    open_source,
    parse_source_spec,
)

__all__ = [
    "AUDIT_ACTIONS",
    "AuditLog",
    "CameraSource",
    "CellService",
    "CertFiles",
    "Conflict",
    "NotFound",
    "OpcUaFace",
    "OpcUaThread",
    "ServiceConfig",
    "ServiceThread",
    "SourceError",
    "StereoGrab",
    "TlsFiles",
    "TokenBook",
    "Unavailable",
    "create_app",
    "exposure_warning",
    "is_loopback",
    "make_certs",
    "open_source",
    "parse_source_spec",
    "pose_stamped",
    "read_audit",
    "read_token",
    "read_tokens",
    "register_from_camera",
    "run_opcua_in_thread",
    "serve",
]
