# The subpackage's public names (lazy_loader.attach_stub reads this file; type
# checkers read it as the package's stub). One list: add a name here only.

from ._bank import (
    BankConfig,
    DescriptorBank,
)
from ._cache import (
    CacheStats,
    PreparedModels,
)
from ._identifier import (
    DEFAULT_PREPARED_MODELS,
    Identifier,
)
from ._identify import (
    Candidate,
    IdentifyConfig,
    IdentifyResult,
    identify,
    identify_in_features,
    identify_with_bank,
)
from ._labels import (
    READ_FORMATS,
    LabelCheck,
    LabelRead,
    check_label,
    read_labels,
)
from ._table import (
    TableConfig,
    TableGarment,
    TableResult,
    identify_all,
)

__all__ = [
    "BankConfig",
    "CacheStats",
    "Candidate",
    "DEFAULT_PREPARED_MODELS",
    "DescriptorBank",
    "Identifier",
    "IdentifyConfig",
    "IdentifyResult",
    "LabelCheck",
    "LabelRead",
    "PreparedModels",
    "READ_FORMATS",
    "TableConfig",
    "TableGarment",
    "TableResult",
    "check_label",
    "identify",
    "identify_all",
    "identify_in_features",
    "identify_with_bank",
    "read_labels",
]
