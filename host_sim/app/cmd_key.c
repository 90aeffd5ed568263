/* host_sim key: the fleet key of a keyed fleet (hal_host_auth.h). */
#include <stdio.h>
#include <string.h>

#include "cli_opts.h"
#include "commands.h"
#include "hal_host_auth.h"

static void key_usage(FILE *out)
{
    fprintf(out, "usage: host_sim key new FILE\n"
                 "       host_sim key check FILE\n"
                 "\n"
                 "A keyed fleet (host_sim run --key-file FILE, tools/fleet --key-file FILE) authenticates every\n"
                 "datagram with an XChaCha20-Poly1305 tag (libsodium) under one 32-byte key that every member holds.\n"
                 "  new FILE    writes a new random key: 64 hexadecimal digits, mode 0600, never over an\n"
                 "              existing file\n"
                 "  check FILE  says whether FILE is a usable key (format, mode 0600 or stricter)\n"
                 "Copy the file to the members' hosts as you would an ssh private key.\n");
}

static const cli_opt_t key_opts[] = {CLI_OPT_END}; /* operands only */

int cmd_key(int argc, char **argv)
{
    char *ops[argc > 0 ? argc : 1];
    int n = 0;
    const cli_parser_t parser = {.cmd = "key", .opts = key_opts, .usage = key_usage, .operands = "words"};
    const int pr = cli_opts_parse(&parser, argc, argv, NULL, ops, &n);
    if (pr != 0)
        return pr > 0 ? 0 : 2;
    if (n != 2 || (strcmp(ops[0], "new") != 0 && strcmp(ops[0], "check") != 0)) {
        fprintf(stderr, "host_sim key: expected 'new FILE' or 'check FILE' (see --help)\n");
        return 2;
    }
    char why[512];
    if (strcmp(ops[0], "new") == 0) {
        if (hal_host_auth_key_new(ops[1], why, sizeof why) != 0) {
            fprintf(stderr, "host_sim key: %s\n", why);
            return 1;
        }
        printf("fleet key written to %s (mode 0600)\n", ops[1]);
        return 0;
    }
    hal_host_auth_t a;
    const int rc = hal_host_auth_key_load(ops[1], a.key, why, sizeof why);
    hal_host_auth_wipe(&a);
    if (rc != 0) {
        fprintf(stderr, "host_sim key: %s\n", why);
        return 1;
    }
    printf("%s: a fleet key\n", ops[1]);
    return 0;
}
