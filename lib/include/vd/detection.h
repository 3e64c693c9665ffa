// SPDX-License-Identifier: MIT
// One detection (a scored box with its origin, track and flags): what the detector outputs and the candidate
// sources, the verifier and overlap suppression (suppress.h) pass along.
#ifndef VD_DETECTION_H
#define VD_DETECTION_H

#include <stdint.h>

#include "vd/image.h"

#ifdef __cplusplus
extern "C" {
#endif

// Where a detection came from (vd_detection_t.source; DESIGN.md JSON "source").
#define VD_DETECTION_SOURCE_HOTSPOT 1u    // "hotspot": hot-spot component, expanded and refined (paper 001)
#define VD_DETECTION_SOURCE_WINDOW 2u     // "window": a sliding window (windows.h), verified as is
#define VD_DETECTION_SOURCE_CONTRAST 3u   // "contrast": a local-contrast component (contrast.h), verified as is
#define VD_DETECTION_SOURCE_CNN 4u        // "cnn": a box decoded from the int8 network (cnn.h); scored by it

// Detection flags (bit set).
#define VD_DETECTION_FLAG_UNVERIFIED 0x01u   // no model: not scored by the DBN (score 255)
#define VD_DETECTION_FLAG_DECIMATED  0x02u   // region larger than max_region_*: refined on a k x k box average
#define VD_DETECTION_FLAG_CONTOUR_TRUNC 0x04u // contour buffers overflowed: the largest of the contours found was used
#define VD_DETECTION_FLAG_RECOVERED  0x08u   // not detected in this frame: recovered by temporal analysis

// One detection.
typedef struct vd_detection {
    vd_rect_t box;               // image coordinates: box of the largest external contour of the refined region
    vd_rect_t candidate;         // image coordinates: the expanded candidate region that was refined
    uint32_t contour_length;     // points of that contour (times k when decimated), 0 for recovered
    uint32_t track_id;           // temporal track (0 = none / temporal off)
    uint16_t complexity_q15;     // edge pixels of the refined region / its pixels (temporal.h)
    uint8_t score_q8;            // DBN p(vehicle) in Q8 (0..255); 255 without a model; 0 for recovered;
                                 //   CNN boxes: the network's score (detector.h cnn_rescore); with track
                                 //   scores (temporal.h VD_TEMPORAL_SCORES) fused with the track's score,
                                 //   recovered: the track's decayed score
    uint8_t source;              // VD_DETECTION_SOURCE_HOTSPOT / _WINDOW / _CONTRAST / _CNN
    uint8_t state;               // vd_track_state_t (VD_TRACK_NONE when temporal is off)
    uint8_t flags;               // VD_DETECTION_FLAG_*
    uint8_t hot_thr;             // 8-bit threshold used (U16 frames: 0 in the fixed grey window, the grey level in their own)
    uint8_t reserved;
} vd_detection_t;

// The names of DESIGN.md's JSON Lines contract, for writers of detections (demo, GStreamer
// element, firmware): "hotspot", "window", "contrast", "cnn" for VD_DETECTION_SOURCE_*, "unknown" otherwise.
VD_API const char *vd_detection_source_name(uint8_t source);
// "confirmed", "recovered", and "new" for VD_TRACK_NEW and VD_TRACK_NONE (temporal analysis off:
// every detection is new to the caller); "unknown" for other values.
VD_API const char *vd_detection_state_name(uint8_t state);

#ifdef __cplusplus
}
#endif
#endif
