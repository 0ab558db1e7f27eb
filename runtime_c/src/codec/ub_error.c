#include "ub/ub_error.h"

const char *ub_strerror(int err) {
    switch (err) {
    case UB_OK: return "UB_OK";
    case UB_ERR_INVAL: return "UB_ERR_INVAL";
    case UB_ERR_NOSPACE: return "UB_ERR_NOSPACE";
    case UB_ERR_TRUNCATED: return "UB_ERR_TRUNCATED";
    case UB_ERR_FULL: return "UB_ERR_FULL";
    case UB_ERR_NOTFOUND: return "UB_ERR_NOTFOUND";
    case UB_ERR_EXISTS: return "UB_ERR_EXISTS";
    case UB_ERR_CHECKSUM: return "UB_ERR_CHECKSUM";
    case UB_ERR_LAYOUT: return "UB_ERR_LAYOUT";
    case UB_ERR_NOROUTE: return "UB_ERR_NOROUTE";
    case UB_ERR_IO: return "UB_ERR_IO";
    case UB_ERR_AGAIN: return "UB_ERR_AGAIN";
    case UB_ERR_CONFIG: return "UB_ERR_CONFIG";
    case UB_ERR_CLOSED: return "UB_ERR_CLOSED";
    case UB_ERR_RANGE: return "UB_ERR_RANGE";
    case UB_ERR_AUTH: return "UB_ERR_AUTH";
    case UB_ERR_UNSUPPORTED: return "UB_ERR_UNSUPPORTED";
    case UB_ERR_REFUSED: return "UB_ERR_REFUSED";
    case UB_ERR_NOANSWER: return "UB_ERR_NOANSWER";
    default: return err >= 0 ? "UB_OK" : "UB_ERR_UNKNOWN";
    }
}
