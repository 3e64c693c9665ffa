// SPDX-License-Identifier: MIT
// Private to port/file: formatting of the one-line error texts the readers and writers return.
#ifndef VD_PORT_FILE_ERR_H
#define VD_PORT_FILE_ERR_H

#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>

#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
static inline void vd_port_set_err(char *err, size_t err_len, const char *fmt, ...)
{
    if (err == NULL || err_len == 0u) {
        return; // the caller did not ask for a text
    }
    va_list ap;
    va_start(ap, fmt);
    (void)vsnprintf(err, err_len, fmt, ap);
    va_end(ap);
}

#endif
