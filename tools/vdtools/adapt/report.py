# SPDX-License-Identifier: MIT
"""vd-adapt's report.md, from the report dict that report.json holds."""
from pathlib import Path


def _pct(v):
    return "–" if v is None else f"{100 * v:.1f}"


def measured(m):
    """choose_resolution's measure as 'half X, full Y, quarter Z': AP@0.5 in per cent, the rating (mean box score + flip
    agreement / 4) as a number."""
    res = [r for r in ("half", "full", "quarter") if r in m]
    if m["measure"].startswith("rating"):
        return ", ".join(f"{r} {m[r]:.3f}" for r in res)
    return ", ".join(f"{r} {_pct(m[r])} %" for r in res)


def _val_row(label, f, bold):
    """One row of the before / after table: measure.figures' f at its threshold."""
    out_ap = f"**{_pct(f['ap_out'])}**" if bold else _pct(f["ap_out"])
    return (f"| {label} | {out_ap} | {_pct(f['ap'])} | {f['thr']:.3f} | {f['tp']} | {f['fp']} | "
            f"{_pct(f['tp_rate'])} % | {_pct(f['fp_rate'])} % |")


def report_md(r):
    f, t = r["frames"], r["training"]
    trained = t["trained"]   # False: an unlabelled run without --self-train kept the networks
    lines = ["# vd-adapt report", "", f"Command: `{r['command']}`", "",
             f"Time taken: {r['time']['wall_s'] / 60:.1f} min wall ("
             + (f"budget {r['time']['minutes_asked']:g} min" if not t["steps_asked"] else f"{t['steps_asked']} steps asked")
             + "; " + ", ".join(f"{k} {v:.0f} s" for k, v in r["time"]["parts_s"].items())
             + f"; {r['time']['this_run_cpu_s'] / 60:.1f} CPU minutes in this run)"
             + (", resumed from a checkpoint" if t["resumed"] else "") + ".", "",
             f"Frames: {f['count']} of {f['size'][0]}×{f['size'][1]}, in blocks of {f['block']} by file name: "
             f"{f['adapt']} to adapt on, {f['val']} to measure on (val; blocks {f['val_blocks']})."]
    if r["labelled"]:
        lab = r["labels"]
        lines += [f"Labels: {lab['kind']}, {lab['matched']} frames labelled (the others have no vehicles), vehicle "
                  f"classes {lab['vehicle_classes']}; {f['adapt_vehicles']} vehicles to adapt on, "
                  f"{f['val_vehicles']} to measure on.", ""]
    elif trained:
        lines += ["Labels: none (self-training on pseudo-labels of the networks themselves, `--self-train`).", ""]
    else:
        lines += ["Labels: none, so **the networks were not trained**: without labels vd-adapt chooses the input "
                  "resolution on your frames and keeps the shipped networks, because self-training on their own "
                  "pseudo-labels lowered AP on every proxy measured with them (docs/results/adapt.md, section E; "
                  "`--self-train` runs it anyway). Label a few dozen frames to adapt the networks themselves.", ""]
    if trained:
        lines += [f"Networks: {', '.join(r['archs'])} from {', '.join(Path(b).name for b in r['base'])}; "
                  f"quantisation-aware fine-tuning, {t['steps']} steps of batch {t['batch']} (lr {t['lr']:g}, "
                  f"{t['threads']} threads)" + (f", {t['rounds']} self-training rounds" if not r["labelled"] else "")
                  + "; training frames of ../shared/data mixed in: "
                  + (", ".join(f"{k} {v} frames" for k, v in r["replay"]["families"].items()) or "none")
                  + f" (crop shares {', '.join(f'{k} {v:.2f}' for k, v in r['replay']['shares'].items())}).", ""]
    else:
        lines += [f"Networks: {', '.join(r['archs'])}, the files of {', '.join(Path(b).name for b in r['base'])} "
                  "unchanged.", ""]
    pol = r["polarity"]
    lines += ["Polarity: " + ("**black-hot** (your frames were inverted, 255 - v, before adaptation; `cnn-polarity` "
                              "in vd.json)" if pol["black_hot"] else "white-hot (as the networks trained)")
              + (f"; {pol['measured']['measure']} of the before networks on all your frames: as they are "
                 f"{pol['measured']['as_is']:.3f}, inverted {pol['measured']['inverted']:.3f}" if pol["measured"]
                 else f" ({pol['chosen_on']})") + ".", ""]
    res = r["resolution"]
    name = res.get("res", "full" if res["full_res"] else "half")
    lines += ["Input resolution: " + {"full": "**full** (`cnn-res` in vd.json: 4x the networks' time and a larger "
                                              "workspace)",
                                      "quarter": "**quarter** (`cnn-res` in vd.json: a quarter of the networks' "
                                                 "time; for vehicles about twice the training size)",
                                      "half": "half (the networks' training scale)"}[name]
              + (f"; {res['measured']['measure']} of the before networks on all your frames: "
                 f"{measured(res['measured'])}" if res["measured"]
                 else f" ({res['chosen_on']})") + ".", ""]
    if r["labelled"]:
        b, bv, a = r["val"]["before"], r["val"]["before_at_val_choice"], r["val"]["after"]
        lines += ["## Before / after on your val frames (the C library, fused flip passes)", "",
                  f"{b['n_frames']} frames, {b['n_vehicles']} vehicles. TP / FP rates: TP / vehicles and "
                  "FP / detections at the threshold.", "",
                  "AP@0.5 of the output ranks the boxes at the row's threshold, what `vd_fir_demo --config "
                  "OUT/vd.json --eval` reports; AP@0.5 of every box ranks them all (the networks' ranking before "
                  "the threshold cuts it).", "",
                  "| networks | AP@0.5 of the output | AP@0.5 of every box | threshold | TP | FP | TP rate | FP rate |",
                  "|---|---:|---:|---:|---:|---:|---:|---:|",
                  _val_row("before, its own threshold", b, False),
                  _val_row("before, threshold chosen on val", bv, False),
                  _val_row("**after** (threshold chosen on val)", a, True), "",
                  "The val part chose the threshold, so its after figures lean optimistic; with few val vehicles "
                  "they are noisy too. Measure on frames of other scenes before you rely on them."]
    else:
        v, ps = r["val"], r.get("pseudo_labels")
        lines += ["## What can be measured without labels", "",
                  "**Without labels the gain is not measured**: these figures say how the output changed, not "
                  "whether it got better.", "",
                  "| on the val frames | before | after |", "|---|---:|---:|",
                  f"| boxes per frame at the threshold ({r['threshold']['after']:.3f}) | "
                  f"{v['boxes_per_frame']['before']:.2f} | {v['boxes_per_frame']['after']:.2f} |",
                  f"| flip agreement (boxes found on the frame and on its mirror image) | "
                  f"{_pct(v['flip_agreement']['before'])} % | {_pct(v['flip_agreement']['after'])} % |", "",
                  f"Boxes in common before / after: {_pct(v['before_after_agreement'])} %." + (
                      "" if ps is None else f" Pseudo-labels per round (score >= {ps['hi']}; {ps['lo']}..{ps['hi']} "
                      "ignored): " + "; ".join(f"round {p['round']}: {p['vehicles']} vehicles in "
                                               f"{p['frames_with_vehicles']} frames, {p['ignore']} ignored"
                                               for p in ps["rounds"]) + ".")]
    dc, ru = r["outputs"]["demo_check"], r["rules"]
    lines += ["", f"Library rules: the adapted files have the same layers and top-K as before "
              f"({'yes' if all(ru['same_layers_and_top_k']) else 'NO'}), so the same multiply-adds; detector "
              f"workspace at {f['size'][0]}×{f['size'][1]} with the flip pass {ru['workspace_bytes']['after']} B "
              f"(before {ru['workspace_bytes']['before']} B); model files {ru['file_bytes']['after']} B.",
              "", "## Outputs", "",
              "- " + ", ".join(f"`{m}`" for m in r["outputs"]["models"]) + ": the "
              + ("adapted" if trained else "shipped (unchanged)") + " int8 networks (header "
              f"threshold {r['threshold']['after']:.3f}); `NAME_vdm.c` / `NAME_vdm.h`: the same bytes as firmware "
              "arrays; `NAME.scales.json`: the export's scales; `float/NAME.npz`: the float weights (to adapt again: "
              "`--base`)" + ("; `before/`: the base networks as quantised here, the before figures' files"
                              if r["before_quantised_here"] else "") + ".",
              "- `vd.json`: `vd_fir_demo --config OUT/vd.json --input FRAMES` (or the GStreamer element's `config` "
              "property) runs them" + (f"; checked with {dc['demo']} on {dc['frame']}" if dc else
                                        "; vd_fir_demo was not found, so it was not run here") + ".", ""]
    return "\n".join(lines)
