// SPDX-License-Identifier: MIT
// Progress of vd_fir_demo on stderr: one updating line on a terminal, plain periodic lines otherwise.
//
// On a terminal (isatty) the line "[done/total pct%] F frames/s, T left | name: n detections"
// is redrawn in place (\r, then erase to the end of the line) at most every
// DEMO_PROGRESS_TTY_S seconds and on the last frame, cut to the terminal's width
// so that it never wraps (a wrapped line cannot be redrawn by \r). Elsewhere (CI
// logs, pipes) one complete line is written every DEMO_PROGRESS_EVERY frames, so a
// log holds a bounded, deterministic number of lines. The rate is the mean since
// the first frame; the time left is (total - done) / rate. total is 0 when unknown
// (a camera without --frames): no percentage and no time left then.
#include "progress.h"

#include <string.h>
#include <sys/ioctl.h>
#include <unistd.h>

#define DEMO_PROGRESS_TTY_S 0.1
#define DEMO_PROGRESS_EVERY 50u

void demo_progress_start(demo_progress_t *p, bool on, bool tty, uint64_t total, double now_s)
{
    memset(p, 0, sizeof *p);
    p->on = on;
    p->tty = tty;
    p->total = total;
    p->t0 = now_s;
    p->last = -1.0;
}

// "1:05:09" or "4:07" (whole seconds, rounded up so that 0:00 means done).
static void fmt_duration(char *buf, size_t cap, double s)
{
    if (!(s >= 0.0)) {
        s = 0.0;
    }
    if (s > 359999.0) {
        s = 359999.0;   // 99:59:59: a rate near zero must not print a huge number
    }
    unsigned long t = (unsigned long)(s + 0.999);
    if (t >= 3600u) {
        snprintf(buf, cap, "%lu:%02lu:%02lu", t / 3600u, t / 60u % 60u, t % 60u);
    } else {
        snprintf(buf, cap, "%lu:%02lu", t / 60u, t % 60u);
    }
}

size_t demo_progress_text(char *buf, size_t cap, uint64_t done, uint64_t total, double elapsed_s,
                          const char *name, size_t n_det)
{
    const double rate = elapsed_s > 0.0 ? (double)done / elapsed_s : 0.0;
    int w;
    if (total > 0) {
        char left[32];
        const uint64_t rest = total > done ? total - done : 0u;
        fmt_duration(left, sizeof left, rate > 0.0 ? (double)rest / rate : 0.0);
        w = snprintf(buf, cap, "[%llu/%llu %.0f%%] %.1f frames/s, %s left | %s: %zu detections",
                     (unsigned long long)done, (unsigned long long)total,
                     100.0 * (double)(done < total ? done : total) / (double)total, rate,
                     rate > 0.0 ? left : "?", name, n_det);
    } else {
        w = snprintf(buf, cap, "[%llu] %.1f frames/s | %s: %zu detections", (unsigned long long)done, rate, name,
                     n_det);
    }
    if (w < 0) {
        buf[0] = '\0';
        return 0;
    }
    return (size_t)w < cap ? (size_t)w : cap - 1u;
}

// Columns of the terminal on stderr (80 when unknown).
static size_t term_columns(void)
{
    struct winsize ws;
    if (ioctl(STDERR_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_col >= 20u) {
        return ws.ws_col;
    }
    return 80u;
}

void demo_progress_frame(demo_progress_t *p, FILE *f, uint64_t done, const char *name, size_t n_det, double now_s)
{
    if (!p->on) {
        return;
    }
    const bool last = p->total > 0 && done >= p->total;
    if (p->tty) {
        if (!last && p->last >= 0.0 && now_s - p->last < DEMO_PROGRESS_TTY_S) {
            return;
        }
        char line[1400];
        size_t l = demo_progress_text(line, sizeof line, done, p->total, now_s - p->t0, name, n_det);
        const size_t cols = term_columns() - 1u;   // the last column would wrap on some terminals
        if (l > cols) {
            line[cols] = '\0';
        }
        fprintf(f, "\r%s\033[K", line);
        fflush(f);
        p->last = now_s;
        p->drawn = true;
        return;
    }
    if (done % DEMO_PROGRESS_EVERY == 0u || last) {
        char line[1400];
        demo_progress_text(line, sizeof line, done, p->total, now_s - p->t0, name, n_det);
        fprintf(f, "%s\n", line);
    }
}

void demo_progress_end(demo_progress_t *p, FILE *f)
{
    if (p->on && p->tty && p->drawn) {
        fputc('\n', f);
    }
    p->drawn = false;
}
