// SPDX-License-Identifier: MIT
// vd status codes: every fallible vd function returns one of these.
#ifndef VD_STATUS_H
#define VD_STATUS_H

#include "vd/config.h"

#ifdef __cplusplus
extern "C" {
#endif

// VD_OK is zero; every error is negative so `if (st < 0)` and `if (st != VD_OK)`
// both work. Values are part of the ABI: append new codes, never renumber.
typedef enum vd_status {
    VD_OK = 0,
    VD_ERR_ARG = -1,         // null pointer, zero or out-of-range size/option
    VD_ERR_WORKSPACE = -2,   // caller buffer null, misaligned or too small
    VD_ERR_CAPACITY = -3,    // an output array filled up: the prefix written is valid, the rest was dropped
    VD_ERR_MODEL = -4,       // model blob malformed: magic, version, sizes or CRC
    VD_ERR_FORMAT = -5,      // pixel format / file format not supported or malformed
    VD_ERR_IO = -6,          // read/write/ioctl failure (port and tools only)
    VD_ERR_TIMEOUT = -7,     // no frame within the timeout
    VD_ERR_RANGE = -8,       // value outside the representable/calibrated range
    VD_ERR_NODEV = -9,       // device missing or lost while streaming
    VD_ERR_STATE = -10,      // call not valid in the object's current state
    VD_ERR_AGAIN = -11,      // try again (non-blocking capture had nothing)
    VD_ERR_OVERFLOW = -12    // size arithmetic on outside dimensions would overflow
} vd_status_t;

// Returns a static, NUL-terminated English text for `st`; never NULL
// ("unknown status" for values not listed above).
VD_API const char *vd_status_str(vd_status_t st);

#ifdef __cplusplus
}
#endif
#endif
