// SPDX-License-Identifier: MIT
// Umbrella header: includes every public vd module.
#ifndef VD_VD_H
#define VD_VD_H

#define VD_VERSION_MAJOR 0
#define VD_VERSION_MINOR 1
#define VD_VERSION_PATCH 0

#include "vd/config.h"
#include "vd/status.h"
#include "vd/image.h"

#endif
