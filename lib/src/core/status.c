// SPDX-License-Identifier: MIT
// Text for vd_status_t values.
#include "vd/status.h"

const char *vd_status_str(vd_status_t st)
{
    switch (st) {
    case VD_OK: return "ok";
    case VD_ERR_ARG: return "invalid argument";
    case VD_ERR_WORKSPACE: return "workspace missing, misaligned or too small";
    case VD_ERR_CAPACITY: return "output capacity exceeded";
    case VD_ERR_MODEL: return "invalid model";
    case VD_ERR_FORMAT: return "unsupported or malformed format";
    case VD_ERR_IO: return "input/output error";
    case VD_ERR_TIMEOUT: return "timed out";
    case VD_ERR_RANGE: return "value out of range";
    case VD_ERR_NODEV: return "no such device";
    case VD_ERR_STATE: return "invalid state for this call";
    case VD_ERR_AGAIN: return "resource temporarily unavailable";
    case VD_ERR_OVERFLOW: return "size arithmetic overflow";
    default: return "unknown status";
    }
}
