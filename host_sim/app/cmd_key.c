/* host_sim key: the fleet key of a keyed fleet (hal_host_auth.h). */
#include <stdio.h>
#include <string.h>

#include "commands.h"
#include "hal_host_auth.h"

static void key_usage(FILE *out)
{
    fprintf(out, "usage: host_sim key new FILE\n"
                 "       host_sim key check FILE\n"
                 "\n"
                 "A keyed fleet (host_sim run --key-file FILE, tools/fleet --key-file FILE) authenticates every\n"
                 "datagram with HMAC-SHA-512-256 (libsodium) under one 32-byte key that every member holds.\n"
                 "  new FILE    writes a new random key: 64 hexadecimal digits, mode 0600, never over an\n"
                 "              existing file\n"
                 "  check FILE  says whether FILE is a usable key (format, mode 0600 or stricter)\n"
                 "Copy the file to the members' hosts as you would an ssh private key.\n");
}

int cmd_key(int argc, char **argv)
{
    if (argc >= 2 && (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0)) {
        key_usage(stdout);
        return 0;
    }
    if (argc != 3 || (strcmp(argv[1], "new") != 0 && strcmp(argv[1], "check") != 0)) {
        fprintf(stderr, "host_sim key: expected 'new FILE' or 'check FILE' (see --help)\n");
        return 2;
    }
    char why[512];
    if (strcmp(argv[1], "new") == 0) {
        if (hal_host_auth_key_new(argv[2], why, sizeof why) != 0) {
            fprintf(stderr, "host_sim key: %s\n", why);
            return 1;
        }
        printf("fleet key written to %s (mode 0600)\n", argv[2]);
        return 0;
    }
    hal_host_auth_t a;
    const int rc = hal_host_auth_key_load(argv[2], a.key, why, sizeof why);
    hal_host_auth_wipe(&a);
    if (rc != 0) {
        fprintf(stderr, "host_sim key: %s\n", why);
        return 1;
    }
    printf("%s: a fleet key\n", argv[2]);
    return 0;
}
