// SPDX-License-Identifier: MIT
// Links vd through find_package(vd) and checks one call end to end.
#include <stdio.h>
#include <string.h>
#include "vd/vd.h"

int main(void)
{
    vd_rect_t a = {0, 0, 10, 10};
    vd_rect_t b = {5, 0, 10, 10};
    uint32_t iou = vd_rect_iou_q15(&a, &b); // 50 / 150 of 32768
    if (iou != 10922u || strcmp(vd_status_str(VD_ERR_WORKSPACE), "workspace missing, misaligned or too small") != 0) {
        printf("consumer: FAIL iou=%u\n", (unsigned)iou);
        return 1;
    }
    printf("consumer: OK (vd %d.%d.%d)\n", VD_VERSION_MAJOR, VD_VERSION_MINOR, VD_VERSION_PATCH);
    return 0;
}
