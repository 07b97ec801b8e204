/*
 * The FMI 2.0 logger is variadic (printf-style), which stable Rust cannot define. This shim
 * formats the message with vsnprintf and hands the finished string to a non-variadic sink.
 *
 * Contract with the Rust side (src/log.rs): componentEnvironment is null or points to a struct
 * whose first member is the sink function pointer; the sink receives that same pointer back.
 * No Rust symbol is referenced by name, so link order does not matter.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

/* fmi2Status is a C enum: int-sized, passed like unsigned int on every supported ABI. */
typedef void (*fmi2_import_sink)(void *env, const char *instance_name, unsigned int status,
                                 const char *category, const char *message);

void fmi2_import_logger(void *env, const char *instance_name, unsigned int status,
                        const char *category, const char *message, ...) {
    char small[1024];
    const char *text = message;
    char *big = NULL;
    fmi2_import_sink sink;
    va_list args;
    int n;

    if (env == NULL) {
        return;
    }
    sink = *(fmi2_import_sink *)env;
    if (sink == NULL) {
        return;
    }
    if (message != NULL) {
        va_start(args, message);
        n = vsnprintf(small, sizeof small, message, args);
        va_end(args);
        if (n < 0) {
            text = "(log message could not be formatted)";
        } else if ((size_t)n < sizeof small) {
            text = small;
        } else {
            big = malloc((size_t)n + 1);
            if (big != NULL) {
                /* A va_list cannot be rewound portably: restart it for the second pass. */
                va_start(args, message);
                vsnprintf(big, (size_t)n + 1, message, args);
                va_end(args);
                text = big;
            } else {
                text = small; /* out of memory: keep the truncated text */
            }
        }
    }
    sink(env, instance_name, status, category, text);
    free(big);
}
