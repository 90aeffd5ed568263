/* A QEMU TCG plugin that counts the instructions a guest program executes, for the Linux boards
 * run under QEMU's user mode (qemu-aarch64), which has no -icount: every translated block adds
 * its instruction count to one counter when it runs (inline, no callback per instruction).
 * The guest marks points of interest with a system call that does not exist
 * (HAL_STDC_MARK_SYSCALL, hal/stdc/hal_stdc_target.h); at each the plugin logs
 *     insn_mark <id> <instructions so far>
 * and at exit `insn_total <n>`. Log with `-d plugin -D FILE`:
 *     qemu-aarch64 -plugin build/.../qemu_insn.so -d plugin -D insn.log IMAGE ...
 * A block left early by an exception still counts whole, so the counts are exact for code
 * that does not fault (ours).
 *
 * Debian ships QEMU's plugin loader but not its header (qemu-plugin.h), so the few functions of
 * the plugin API used here (version 1, QEMU 4.2 to 7.2) are declared below; QEMU checks
 * qemu_plugin_version when it loads the plugin and refuses another. */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#define HAL_STDC_MARK_SYSCALL 4085 /* as hal/stdc/hal_stdc_target.h */
#define EXPORT __attribute__((visibility("default")))

typedef uint64_t qemu_plugin_id_t;
typedef struct qemu_info_t qemu_info_t;
struct qemu_plugin_tb;
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };

void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id,
                                           void (*cb)(qemu_plugin_id_t, struct qemu_plugin_tb *));
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb *tb, enum qemu_plugin_op op,
                                              void *ptr, uint64_t imm);
void qemu_plugin_register_vcpu_syscall_cb(qemu_plugin_id_t id,
                                          void (*cb)(qemu_plugin_id_t, unsigned int, int64_t, uint64_t,
                                                     uint64_t, uint64_t, uint64_t, uint64_t, uint64_t,
                                                     uint64_t, uint64_t));
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, void (*cb)(qemu_plugin_id_t, void *),
                                    void *userdata);
void qemu_plugin_outs(const char *string);

EXPORT int qemu_plugin_version = 1;
EXPORT int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv);

static uint64_t executed; /* one guest thread: the board image runs on one */

static void on_translate(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    (void)id;
    qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &executed,
                                             qemu_plugin_tb_n_insns(tb));
}

static void on_syscall(qemu_plugin_id_t id, unsigned int vcpu, int64_t num, uint64_t a1, uint64_t a2,
                       uint64_t a3, uint64_t a4, uint64_t a5, uint64_t a6, uint64_t a7, uint64_t a8)
{
    (void)id, (void)vcpu, (void)a2, (void)a3, (void)a4, (void)a5, (void)a6, (void)a7, (void)a8;
    if (num != HAL_STDC_MARK_SYSCALL)
        return;
    char line[64];
    snprintf(line, sizeof line, "insn_mark %llu %llu\n", (unsigned long long)a1,
             (unsigned long long)executed);
    qemu_plugin_outs(line);
}

static void on_exit(qemu_plugin_id_t id, void *unused)
{
    (void)id, (void)unused;
    char line[48];
    snprintf(line, sizeof line, "insn_total %llu\n", (unsigned long long)executed);
    qemu_plugin_outs(line);
}

int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv)
{
    (void)info, (void)argc, (void)argv;
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_translate);
    qemu_plugin_register_vcpu_syscall_cb(id, on_syscall);
    qemu_plugin_register_atexit_cb(id, on_exit, NULL);
    return 0;
}
