// SPDX-License-Identifier: MIT
// Names of a detection's source and track state: the strings of DESIGN.md's JSON Lines contract,
// kept in one place for everything that writes detections.
#include "vd/detection.h"

#include "vd/temporal.h"

const char *vd_detection_source_name(uint8_t source)
{
    switch (source) {
    case VD_DETECTION_SOURCE_HOTSPOT: return "hotspot";
    case VD_DETECTION_SOURCE_WINDOW: return "window";
    case VD_DETECTION_SOURCE_CONTRAST: return "contrast";
    case VD_DETECTION_SOURCE_CNN: return "cnn";
    default: return "unknown";
    }
}

const char *vd_detection_state_name(uint8_t state)
{
    switch (state) {
    case VD_TRACK_NONE:
    case VD_TRACK_NEW: return "new";
    case VD_TRACK_CONFIRMED: return "confirmed";
    case VD_TRACK_RECOVERED: return "recovered";
    default: return "unknown";
    }
}
