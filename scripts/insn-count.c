/*
 * Minimal QEMU TCG plugin: counts the guest instructions executed (all vCPUs) and their bytes of code,
 * and prints the totals at exit as "insns <n>" and "bytes <n>". Debian's QEMU loads plugins but ships no qemu-plugin.h, so the few API
 * declarations used are written out here (plugin API version 1, QEMU 7.x).
 *
 * Optional marks (addresses of functions of the guest program, e.g. from llvm-nm):
 *   hop=ADDR     each time ADDR is entered, print "hop <n> <b>": instructions (and their bytes of
 *                code) counted since the last "hop" (or since the start), not counting the paused
 *                stretches;
 *   pause=ADDR   entering ADDR stops the count of the "hop" lines ...
 *   resume=ADDR  ... and entering ADDR starts it again (input generation is left out this way).
 * The total at exit counts everything.
 *
 * Build: gcc -O2 -shared -fPIC -o insn-count.so insn-count.c
 * Use:   qemu-system-arm ... -plugin ./insn-count.so[,hop=0x…,pause=0x…,resume=0x…] -d plugin
 */
#include <inttypes.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <stddef.h>

typedef uint64_t qemu_plugin_id_t;
struct qemu_info_t;
struct qemu_plugin_tb;
enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS };
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb *tb);
typedef void (*qemu_plugin_udata_cb_t)(qemu_plugin_id_t id, void *userdata);
typedef void (*qemu_plugin_vcpu_udata_cb_t)(unsigned int vcpu_index, void *userdata);

void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, qemu_plugin_vcpu_tb_trans_cb_t cb);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
struct qemu_plugin_insn;
struct qemu_plugin_insn *qemu_plugin_tb_get_insn(const struct qemu_plugin_tb *tb, size_t idx);
size_t qemu_plugin_insn_size(const struct qemu_plugin_insn *insn);
uint64_t qemu_plugin_tb_vaddr(const struct qemu_plugin_tb *tb);
void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb *tb, enum qemu_plugin_op op,
                                              void *ptr, uint64_t imm);
void qemu_plugin_register_vcpu_tb_exec_cb(struct qemu_plugin_tb *tb, qemu_plugin_vcpu_udata_cb_t cb,
                                          enum qemu_plugin_cb_flags flags, void *userdata);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, qemu_plugin_udata_cb_t cb, void *userdata);
void qemu_plugin_outs(const char *string);

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

enum mark { MARK_HOP, MARK_PAUSE, MARK_RESUME, MARKS };
static const char *mark_names[MARKS] = {"hop=", "pause=", "resume="};
/* Thumb code: the symbol's bit 0 is not part of the address; ~0 = not set. */
static uint64_t mark_addr[MARKS] = {~0ull, ~0ull, ~0ull};

static uint64_t insns, bytes;
/* Instructions (and bytes) in paused stretches so far, where the current one started, and the last
 * hop's end. */
static uint64_t paused_total, paused_at, last_hop;
static uint64_t paused_bytes, paused_bytes_at, last_hop_bytes;
static int paused;

static void on_mark(unsigned int vcpu, void *udata)
{
    (void)vcpu;
    switch ((enum mark)(uintptr_t)udata) {
    case MARK_HOP: {
        char buf[64];
        uint64_t now = insns - paused_total;
        uint64_t now_bytes = bytes - paused_bytes;
        snprintf(buf, sizeof buf, "hop %" PRIu64 " %" PRIu64 "\n", now - last_hop,
                 now_bytes - last_hop_bytes);
        qemu_plugin_outs(buf);
        last_hop = now;
        last_hop_bytes = now_bytes;
        break;
    }
    case MARK_PAUSE:
        if (!paused) {
            paused = 1;
            paused_at = insns;
            paused_bytes_at = bytes;
        }
        break;
    case MARK_RESUME:
        if (paused) {
            paused = 0;
            paused_total += insns - paused_at;
            paused_bytes += bytes - paused_bytes_at;
        }
        break;
    default:
        break;
    }
}

static void tb_trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    (void)id;
    /* Every execution of this translation block adds its instruction count and size. */
    size_t n = qemu_plugin_tb_n_insns(tb);
    uint64_t size = 0;
    for (size_t i = 0; i < n; i++) {
        size += qemu_plugin_insn_size(qemu_plugin_tb_get_insn(tb, i));
    }
    qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &insns, n);
    qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &bytes, size);
    uint64_t pc = qemu_plugin_tb_vaddr(tb);
    for (int m = 0; m < MARKS; m++) {
        if (pc == mark_addr[m]) {
            qemu_plugin_register_vcpu_tb_exec_cb(tb, on_mark, QEMU_PLUGIN_CB_NO_REGS,
                                                 (void *)(uintptr_t)m);
        }
    }
}

static void at_exit(qemu_plugin_id_t id, void *p)
{
    char buf[64];
    (void)id;
    (void)p;
    snprintf(buf, sizeof buf, "insns %" PRIu64 "\nbytes %" PRIu64 "\n", insns, bytes);
    qemu_plugin_outs(buf);
}

__attribute__((visibility("default"))) int qemu_plugin_install(qemu_plugin_id_t id,
                                                               const struct qemu_info_t *info,
                                                               int argc, char **argv)
{
    (void)info;
    for (int i = 0; i < argc; i++) {
        for (int m = 0; m < MARKS; m++) {
            size_t n = strlen(mark_names[m]);
            if (strncmp(argv[i], mark_names[m], n) == 0) {
                mark_addr[m] = strtoull(argv[i] + n, NULL, 0) & ~1ull;
            }
        }
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, tb_trans);
    qemu_plugin_register_atexit_cb(id, at_exit, NULL);
    return 0;
}
