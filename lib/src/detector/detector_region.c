// SPDX-License-Identifier: MIT
// The detector's per-candidate work: the region plane, refinement and contour of hot spots, the 32x32 sample
// and its DBN score, and the complexity probe of temporal recovery.
//
// Algorithm (paper 001 sections 3-4): a hot-spot component is expanded
// (vd_rect_expand, 1.5x by 2x), its region refined (refine.h: median, Otsu,
// holes, edges, local max-distance thresholds) and traced (contour.h); the
// outer contour with the largest box gives the detection box. Every merged
// candidate is then resampled to the model's input (resample.h; grey mode:
// the plane under the box, shape mode: the box refined again, as
// tools/vdtools/data/samples.py makes training samples) and scored (dbn.h).
// Region plane: 8-bit regions within max_region_w x max_region_h are read
// from the frame (so the median sees the pixels around the ROI); larger
// regions are box-averaged by per-axis factors kx, ky (vd_resample_box_*),
// and 16-bit regions are mapped to grey (vd_calib_grey_u8), into the
// overlay's crop buffer.
// Bounds: O(region) per candidate for the plane, refine and contour, plus the
// DBN's multiply-adds; state in the workspace (cand_ctx_t); stack: the deepest
// chain is vd_refine_region -> median (docs/embedded.md); no recursion.
#include <string.h>

#include "vd/resample.h"
#include "detector/detector_internal.h"
#include "internal/vd_internal.h"

// Builds the region plane in the overlay's crop buffer when needed (16-bit
// frames, or regions above max_region_*); 8-bit regions that fit are read
// from the frame directly so the median sees the pixels around the ROI.
VD_DET_NOINLINE static vd_status_t make_plane(vd_detector_t *det, const vd_frame_t *f, const vd_rect_t *region,
                              uint8_t *crop, region_plane_t *p)
{
    uint32_t rw = (uint32_t)region->w;
    uint32_t rh = (uint32_t)region->h;
    uint32_t mw = det->cfg.max_region_w;
    uint32_t mh = det->cfg.max_region_h;
    p->region = *region;
    p->kx = (rw + mw - 1u) / mw;
    p->ky = (rh + mh - 1u) / mh;
    if (f->format == VD_PIX_U8 && p->kx == 1u && p->ky == 1u) {
        VD_TRY(vd_frame_view_u8(f, &p->view));
        p->roi = *region;
        return VD_OK;
    }
    const uint32_t cw = rw / p->kx;
    const uint32_t ch = rh / p->ky;
    vd_image_u8_t out = {crop, cw, ch, cw};
    if (f->format == VD_PIX_U8) {
        vd_view_u8_t v;
        VD_TRY(vd_frame_view_u8(f, &v));
        VD_TRY(vd_resample_box_u8(&v, region, p->kx, p->ky, &out));
    } else {
        vd_view_u16_t v;
        VD_TRY(vd_frame_view_u16(f, &v));
        VD_TRY(vd_resample_box_u16(&v, region, p->kx, p->ky, &det->grey, &out));
    }
    p->view = vd_image_u8_view(&out);
    p->roi.x = 0;
    p->roi.y = 0;
    p->roi.w = (int32_t)cw;
    p->roi.h = (int32_t)ch;
    return VD_OK;
}

// Refines x->region into x->b.rmask; sets x->p (its plane), x->m and x->rs.
static vd_status_t refine_region(vd_detector_t *det, const vd_frame_t *f, cand_ctx_t *x)
{
    VD_TRY(make_plane(det, f, &x->region, x->b.crop, &x->p));
    x->m.data = x->b.rmask;
    x->m.width = (uint32_t)x->p.roi.w;
    x->m.height = (uint32_t)x->p.roi.h;
    x->m.stride = (size_t)x->p.roi.w;
    return vd_refine_region(&x->p.view, &x->p.roi, &x->rc, x->b.refine_ws, det->refine_ws_bytes, &x->m, &x->rs);
}

// Complexity (temporal.h) of a refined region: edge pixels / region pixels.
// A mask that is empty or covers the whole region has no object outline (a
// uniform region makes Otsu keep everything and its only "edges" are the
// region border), so it counts as 0, which never resembles a vehicle.
static uint16_t region_complexity(const vd_refine_stats_t *rs, const region_plane_t *p)
{
    uint32_t area = (uint32_t)p->roi.w * (uint32_t)p->roi.h;
    if (rs->fg_pixels == 0u || rs->fg_pixels >= area) {
        return 0u;
    }
    return vd_temporal_complexity_q15(rs->edge_points, area);
}

vd_status_t vd__detector_probe(void *user, const vd_rect_t *box, uint16_t *complexity_q15)
{
    vd_detector_t *det = (vd_detector_t *)user;
    const vd_frame_t *f = det->frame;
    cand_ctx_t *x = (cand_ctx_t *)det->scratch;
    VD_TRY(vd_rect_expand(box, det->cfg.expand_w_q8, det->cfg.expand_h_q8, f->width, f->height, &x->region));
    VD_TRY(refine_region(det, f, x));
    *complexity_q15 = region_complexity(&x->rs, &x->p);
    return VD_OK;
}

// Index of the contour with the largest box area (then length; first wins).
static size_t largest_contour(const vd_contour_t *c, size_t n)
{
    size_t best = 0u;
    for (size_t i = 1; i < n; i++) {
        uint64_t ai = (uint64_t)c[i].box.w * (uint64_t)c[i].box.h;
        uint64_t ab = (uint64_t)c[best].box.w * (uint64_t)c[best].box.h;
        if (ai > ab || (ai == ab && c[i].length > c[best].length)) {
            best = i;
        }
    }
    return best;
}

vd_status_t vd__detector_refine_hot(vd_detector_t *det, const vd_frame_t *f, const vd_component_t *comp,
                              vd_detection_t *d, bool *ok, uint32_t *t0)
{
    cand_ctx_t *x = (cand_ctx_t *)det->scratch;
    *ok = false;
    memset(d, 0, sizeof(*d));
    if (vd_rect_expand(&comp->box, det->cfg.expand_w_q8, det->cfg.expand_h_q8, f->width, f->height, &x->region) !=
        VD_OK) {
        return VD_OK;   // cannot happen for a component inside the frame
    }
    VD_TRY(refine_region(det, f, x));
    const region_plane_t *p = &x->p;
    if (p->kx > 1u || p->ky > 1u) {
        d->flags |= VD_DETECTION_FLAG_DECIMATED;
        det->stats.decimated++;
    }
    vd__detector_clock_add(det, VD_DETECTOR_STAGE_REFINE, t0);

    x->mv = vd_image_u8_view(&x->m);
    size_t nc = 0u;
    size_t np = 0u;
    vd_status_t st = vd_contour_find_external(&x->mv, x->b.contour_ws, det->contour_ws_bytes, x->b.points, NULL,
                                               det->points_cap, x->b.contours, det->contours_cap, &nc, &np);
    if (st == VD_ERR_CAPACITY) {
        d->flags |= VD_DETECTION_FLAG_CONTOUR_TRUNC;
        det->stats.overflow_contours++;
    } else if (st != VD_OK) {
        return st;
    }
    vd__detector_clock_add(det, VD_DETECTOR_STAGE_CONTOUR, t0);
    if (nc == 0u) {
        return VD_OK;
    }
    det->stats.refined++;
    x->best = x->b.contours[largest_contour(x->b.contours, nc)];
    const vd_contour_t *c = &x->best;
    uint32_t kmax = p->kx > p->ky ? p->kx : p->ky;
    d->box.x = x->region.x + c->box.x * (int32_t)p->kx;
    d->box.y = x->region.y + c->box.y * (int32_t)p->ky;
    d->box.w = c->box.w * (int32_t)p->kx;
    d->box.h = c->box.h * (int32_t)p->ky;
    d->candidate = x->region;
    d->contour_length = c->length * kmax;
    d->complexity_q15 = region_complexity(&x->rs, p);
    d->source = (uint8_t)VD_DETECTION_SOURCE_HOTSPOT;
    *ok = true;
    return VD_OK;
}

// Paper 003's verifier on the box vb of the region plane: crop_w x crop_h
// grey sample, boosted stumps over the selected CNN maps (boost.h).
static vd_status_t verify_boost(vd_detector_t *det, const vd_view_u8_t *view, const vd_rect_t *vb, vd_detection_t *d,
                                bool *keep, uint32_t *t0)
{
    const vd_boost_model_t *bm = det->cfg.boost_model;
    VD_TRY(vd_resample_u8(view, vb, det->sample, bm->crop_w, bm->crop_h));
    vd__detector_clock_add(det, VD_DETECTOR_STAGE_SAMPLE, t0);
    int32_t s = 0;
    VD_TRY(vd_boost_score(bm, det->sample, bm->crop_w, det->dbn_ws, det->dbn_ws_bytes, &s));
    vd__detector_clock_add(det, VD_DETECTOR_STAGE_DBN, t0);
    // Floor division, so score_q8 >= 128 exactly when score >= the model's threshold.
    const int64_t num = ((int64_t)s - bm->threshold) * 128;
    const int64_t span = bm->score_span;
    int64_t q = 128 + ((num >= 0) ? num / span : -((-num + span - 1) / span));
    q = (q < 0) ? 0 : ((q > 255) ? 255 : q);
    d->score_q8 = (uint8_t)q;
    if ((int64_t)s < (int64_t)bm->threshold + det->cfg.boost_thr_offset) {
        return VD_OK;
    }
    det->stats.verified++;
    *keep = true;
    return VD_OK;
}

// The plane is rebuilt from d->candidate: hot spots are sampled under their
// contour box inside the refined region, windows, contrast and re-scored CNN
// candidates (candidate == box) as the whole box; other CNN boxes keep the
// network's score.
vd_status_t vd__detector_verify(vd_detector_t *det, const vd_frame_t *f, vd_detection_t *d, bool *keep, uint32_t *t0)
{
    cand_ctx_t *x = (cand_ctx_t *)det->scratch;
    *keep = false;
    if (d->source == VD_DETECTION_SOURCE_CNN && det->cfg.cnn_rescore == 0u) {
        det->stats.verified++;   // scored by the network already
        *keep = true;
        return VD_OK;
    }
    const bool boost = det->cfg.verifier == VD_DETECTOR_VERIFIER_BOOST;
    if (!boost && det->model == NULL) {
        d->score_q8 = 255u;
        d->flags |= VD_DETECTION_FLAG_UNVERIFIED;
        det->stats.verified++;
        *keep = true;
        return VD_OK;
    }
    const region_plane_t *p = &x->p;
    VD_TRY(make_plane(det, f, &d->candidate, x->b.crop, &x->p));
    if (d->source != VD_DETECTION_SOURCE_HOTSPOT && (p->kx > 1u || p->ky > 1u)) {
        d->flags |= VD_DETECTION_FLAG_DECIMATED;
    }
    // The box in plane coordinates (exact: a hot-spot box is region + k * contour box).
    x->vb.x = p->roi.x + (d->box.x - d->candidate.x) / (int32_t)p->kx;
    x->vb.y = p->roi.y + (d->box.y - d->candidate.y) / (int32_t)p->ky;
    x->vb.w = d->box.w / (int32_t)p->kx;
    x->vb.h = d->box.h / (int32_t)p->ky;
    x->vb.w = (x->vb.w < 1) ? 1 : x->vb.w;
    x->vb.h = (x->vb.h < 1) ? 1 : x->vb.h;
    if (boost) {
        return verify_boost(det, &p->view, &x->vb, d, keep, t0);
    }
    if (det->model->input_mode == VD_DBN_INPUT_GREY) {
        VD_TRY(vd_resample_u8(&p->view, &x->vb, det->sample, det->in_w, det->in_h));
    } else {
        // As samples.py: refine the box itself, then resample the whole mask.
        x->m.data = x->b.rmask;
        x->m.width = (uint32_t)x->vb.w;
        x->m.height = (uint32_t)x->vb.h;
        x->m.stride = (size_t)x->vb.w;
        VD_TRY(vd_refine_region(&p->view, &x->vb, &x->rc, x->b.refine_ws, det->refine_ws_bytes, &x->m, NULL));
        x->mv = vd_image_u8_view(&x->m);
        VD_TRY(vd_resample_u8(&x->mv, NULL, det->sample, det->in_w, det->in_h));
    }
    vd__detector_clock_add(det, VD_DETECTOR_STAGE_SAMPLE, t0);
    uint8_t score = 0u;
    VD_TRY(vd_dbn_classify(det->model, det->sample, det->dbn_ws, det->dbn_ws_bytes, &score));
    vd__detector_clock_add(det, VD_DETECTOR_STAGE_DBN, t0);
    d->score_q8 = score;
    if (score < det->cfg.score_thr_q8) {
        return VD_OK;
    }
    det->stats.verified++;
    *keep = true;
    return VD_OK;
}
