// SPDX-License-Identifier: MIT
// Umbrella header: includes every public vd module.
#ifndef VD_VD_H
#define VD_VD_H

#define VD_VERSION_MAJOR 0
#define VD_VERSION_MINOR 2
#define VD_VERSION_PATCH 0

#include "vd/config.h"
#include "vd/status.h"
#include "vd/rect.h"
#include "vd/image.h"
#include "vd/calib.h"
#include "vd/threshold.h"
#include "vd/histogram.h"
#include "vd/otsu.h"
#include "vd/median.h"
#include "vd/refine.h"
#include "vd/contour.h"
#include "vd/components.h"
#include "vd/windows.h"
#include "vd/contrast.h"
#include "vd/resample.h"
#include "vd/dbn.h"
#include "vd/cnn.h"
#include "vd/boost.h"
#include "vd/temporal.h"
#include "vd/detection.h"
#include "vd/suppress.h"
#include "vd/detector.h"
#include "vd/deprecated.h"   // 0.1 names, one release (VD_NO_DEPRECATED removes them)

#endif
