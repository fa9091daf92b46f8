/* A downstream C99 program that sees only the installed header and library. */
#include <stdio.h>
#include <string.h>

#include <lidarflow/lidarflow.h>

int main(void) {
    if (lf_version_number() != LF_VERSION_NUMBER) {
        fprintf(stderr, "header %s / library %s mismatch\n", LF_VERSION_STRING, lf_version_string());
        return 1;
    }
    if (strcmp(lf_status_string(LF_ERR_FORMAT), "corrupt or unsupported format") != 0) return 1;
    printf("lidarflow %s (ABI %u) ok\n", lf_version_string(), (unsigned)lf_abi_major());
    return 0;
}
