/* The shared-memory transport of the host network (hal_host_net_transport.h), for the robots of
 * one host: "shm://NAME" (host_sim run --transport shm; tools/fleet --transport shm). The
 * segment and its rings are hal_host_net_shm_seg.h.
 *
 * Why: with 64 robots on 2 cores, a round over LCM multicast spent about a sixth of the
 * fleet's CPU in the kernel's receive path (a copy per receiver of every datagram, buffers,
 * a wake-up per datagram) and a fourteenth on the fleet key's tag. Here a datagram is written
 * once into its writer's ring and each robot that wants it copies it out; nothing else moves.
 *
 * Delivery is scoped at the writer. Each robot's slot holds its subscriptions (channel hashes
 * and, where narrowed by hal_host_net_set_senders, the wanted senders' bits); after writing a
 * datagram, the writer marks it in each robot that wants it (`first`: where that robot's walk
 * through this writer's ring starts) and rings the robot's doorbell if it sleeps (`armed`). A
 * robot therefore never reads, nor is woken for, what it does not want.
 *
 * The doorbell is an abstract Unix datagram socket per slot, "\0fleetsim-shm:NAME:SLOT": its
 * descriptor is what the GP core polls (inline_fd). A robot arms before it sleeps, then looks
 * once more (each side stores, fences and reads the other's flag: one of the two sees the
 * other), so a wake-up is never lost, and while it is awake or already rung its writers ring
 * nothing: a burst of chunks costs one wake-up, not one per datagram.
 *
 * One copy on the way: the GP core's receive takes the next wanted datagram from its writer's
 * ring straight into the GP core's buffer (take_into: a pread of the segment), where
 * hal_host_net.c checks it; over a socket a datagram was copied into a receive buffer, the
 * queue and then the GP core's buffer. Until the GP core's first wait or receive nothing is
 * read at all (the receiver thread sleeps): the rings hold it, as a socket's buffer would.
 *
 * No tag: the segment is created 0600, the fleet key's own mode, so whoever can write the
 * segment can read the key (hal_host_net_transport_t.trusted_host). The datagram's checks
 * (hal_host_msg_check, the state's CRC) hold as on any transport.
 *
 * What a reader lost because its writer lapped it is counted with the queue's drops
 * (hal_net_stats_t.rx_dropped_full), once per lap: the protocol asks for it again. A slot whose
 * owner died is taken over by a later process only when every slot was claimed once. */
#include "hal_host_net_shm_seg.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#define SHM_NAME_MAX 48u
#define SHM_MAGIC (0x66736e6574736d31ull ^ ((uint64_t)SHM_SEGMENT_BYTES << 8) ^ (uint64_t)SHM_SLOTS)

typedef struct shm_ctx {
    hal_host_net_t *n;
    char name[SHM_NAME_MAX + 1];
    int fd;                   /* the segment: the rings are read and written through it */
    uint8_t *base;            /* the mapping of its header and slots (SHM_MAPPED_BYTES) */
    shm_header_t *hdr;
    uint32_t me;              /* our slot */
    shm_slot_t *slot;         /* ours */
    int bell;                 /* our doorbell: bound, nonblocking; also rings the others' */
    int rung;                 /* a byte we sent ourselves waits in it */
    pthread_mutex_t mu;       /* our subscription table (the caller's thread writes it) */
    uint32_t n_chan;          /* our subscriptions (the segment's copy is only what writers read) */
    char chan[HAL_HOST_NET_MAX_SUBS][HAL_NET_CHANNEL_MAX];
    /* The reader's own, per writer and ring: where it has read to, and, when `peeked`, the
       header of the wanted entry there, not yet taken. */
    uint64_t pos[2][SHM_SLOTS];
    uint8_t peeked[2][SHM_SLOTS];
    shm_entry_t peek[2][SHM_SLOTS];
    uint8_t rx[SHM_DATAGRAM_MAX];
    /* take_into's: where the next wanted datagram goes instead of hal_host_net_on_datagram
       (buf NULL: none), and what became of it (got: 1, -EMSGSIZE, 0: nothing yet). */
    struct {
        char *channel;
        void *buf;
        size_t cap, len;
        int got;
    } sink;
    int takes_first;          /* take_into was used: hal_host_net_rx.c looks before it sleeps */
    int told_full;            /* a write to the segment failed and stderr was told */
} shm_ctx_t;

static shm_slot_t *slot_at(const shm_ctx_t *c, uint32_t i)
{
    return (shm_slot_t *)(c->base + sizeof(shm_header_t)) + i;
}

/* 1 + the highest slot claimed, as the segment says (bounded: anyone of this user can write it). */
static uint32_t slots_in_use(const shm_ctx_t *c)
{
    const uint32_t hi = atomic_load(&c->hdr->hi);
    return hi < SHM_SLOTS ? hi : SHM_SLOTS;
}

static socklen_t bell_addr(const shm_ctx_t *c, uint32_t slot, struct sockaddr_un *a)
{
    memset(a, 0, sizeof *a);
    a->sun_family = AF_UNIX;
    const int w = snprintf(a->sun_path + 1, sizeof a->sun_path - 1u, "fleetsim-shm:%s:%u", c->name, slot);
    return (socklen_t)(offsetof(struct sockaddr_un, sun_path) + 1u + (size_t)w);
}

static void ring_bell(shm_ctx_t *c, uint32_t slot)
{
    struct sockaddr_un a;
    const socklen_t len = bell_addr(c, slot, &a);
    /* Full (it is rung already) or gone (its robot died): either way nothing to do. */
    (void)sendto(c->bell, "", 1, MSG_DONTWAIT, (const struct sockaddr *)&a, len);
}

/* A slot of our own: a free one, else one whose owner is gone. -ENOSPC when none. */
static int claim_slot(shm_ctx_t *c)
{
    const uint32_t pid = (uint32_t)getpid();
    for (int pass = 0; pass < 2; pass++)
        for (uint32_t i = 0; i < SHM_SLOTS; i++) {
            shm_slot_t *s = slot_at(c, i);
            uint32_t owner = atomic_load(&s->owner);
            if (pass == 0 ? owner != 0 : owner == 0 || kill((pid_t)owner, 0) == 0 || errno != ESRCH)
                continue;
            if (!atomic_compare_exchange_strong(&s->owner, &owner, pid))
                continue;
            c->me = i;
            c->slot = s;
            uint32_t hi = atomic_load(&c->hdr->hi);
            while (hi < i + 1u && !atomic_compare_exchange_weak(&c->hdr->hi, &hi, i + 1u)) {
            }
            return 0;
        }
    return -ENOSPC;
}

static void shm_close(void *ctx)
{
    shm_ctx_t *c = ctx;
    if (c == NULL)
        return;
    if (c->bell >= 0)
        close(c->bell);
    if (c->slot != NULL) {
        shm_slot_clear_subs(c->slot);
        atomic_store(&c->slot->armed, 0u);
        atomic_store(&c->slot->owner, 0u);
    }
    if (c->base != NULL)
        munmap(c->base, SHM_MAPPED_BYTES);
    if (c->fd >= 0)
        close(c->fd);
    pthread_mutex_destroy(&c->mu);
    free(c);
}

static int valid_name(const char *s)
{
    size_t k = 0;
    for (; s[k] != '\0'; k++)
        if (k == SHM_NAME_MAX || !((s[k] >= 'a' && s[k] <= 'z') || (s[k] >= 'A' && s[k] <= 'Z') ||
                                   (s[k] >= '0' && s[k] <= '9') || s[k] == '-' || s[k] == '_' || s[k] == '.'))
            return 0;
    return k > 0;
}

/* Opens the segment /fleetsim.NAME, creating it (0600, sparse) when it does not exist, and maps
 * its header and slots (their pages allocated first: a full /dev/shm is an error here rather
 * than a SIGBUS at the first touch). */
static int map_segment(shm_ctx_t *c)
{
    char path[SHM_NAME_MAX + 16];
    snprintf(path, sizeof path, "/fleetsim.%s", c->name);
    const int fd = shm_open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0600);
    if (fd < 0) {
        fprintf(stderr, "hal_host_net: shm://%s: shm_open %s: %s\n", c->name, path, strerror(errno));
        return -EIO;
    }
    struct stat st;
    int rc = fstat(fd, &st) == 0 ? 0 : -EIO;
    if (rc == 0 && st.st_uid != getuid()) {
        fprintf(stderr, "hal_host_net: shm://%s: /dev/shm%s belongs to another user\n", c->name, path);
        rc = -EIO;
    } else if (rc == 0 && st.st_size == 0 && ftruncate(fd, (off_t)SHM_SEGMENT_BYTES) != 0) {
        fprintf(stderr, "hal_host_net: shm://%s: sizing %s: %s\n", c->name, path, strerror(errno));
        rc = -EIO;
    } else if (rc == 0 && st.st_size != 0 && (uint64_t)st.st_size != SHM_SEGMENT_BYTES) {
        fprintf(stderr, "hal_host_net: shm://%s: /dev/shm%s is %lld bytes, this build's layout %llu: a fleet of "
                        "another build uses the name\n", c->name, path, (long long)st.st_size,
                (unsigned long long)SHM_SEGMENT_BYTES);
        rc = -EIO;
    }
    if (rc == 0 && (errno = posix_fallocate(fd, 0, (off_t)SHM_MAPPED_BYTES)) != 0) {
        fprintf(stderr, "hal_host_net: shm://%s: %llu bytes for %s: %s (/dev/shm full?)\n", c->name,
                (unsigned long long)SHM_MAPPED_BYTES, path, strerror(errno));
        rc = -EIO;
    }
    if (rc == 0) {
        void *m = mmap(NULL, SHM_MAPPED_BYTES, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
        if (m == MAP_FAILED) {
            fprintf(stderr, "hal_host_net: shm://%s: mmap: %s\n", c->name, strerror(errno));
            rc = -EIO;
        } else {
            c->base = m;
            c->hdr = m;
            /* No fault-around: a read of one slot's word would map the 64 KB about it, and the
               slots' 19 MB ended up in every robot's RSS. */
            (void)posix_madvise(m, SHM_MAPPED_BYTES, POSIX_MADV_RANDOM);
        }
    }
    c->fd = fd;
    if (rc != 0)
        return rc;
    uint64_t magic = 0;
    if (!atomic_compare_exchange_strong(&c->hdr->magic, &magic, SHM_MAGIC) && magic != SHM_MAGIC) {
        fprintf(stderr, "hal_host_net: shm://%s: /dev/shm%s is not a segment of this build's layout\n", c->name, path);
        return -EIO;
    }
    return 0;
}

static int shm_open_url(hal_host_net_t *n, const char *url, void **ctx)
{
    *ctx = NULL;
    const char *name = url + 6; /* "shm://" */
    if (!valid_name(name)) {
        fprintf(stderr, "hal_host_net: '%s': not shm://NAME (1-%u letters, digits, '.', '-', '_')\n", url, SHM_NAME_MAX);
        return -EINVAL;
    }
    shm_ctx_t *c = calloc(1, sizeof *c);
    if (c == NULL)
        return -EIO;
    c->n = n;
    c->bell = c->fd = -1;
    memcpy(c->name, name, strlen(name) + 1u);
    pthread_mutex_init(&c->mu, NULL);
    int rc = map_segment(c);
    if (rc == 0 && (rc = claim_slot(c)) != 0)
        fprintf(stderr, "hal_host_net: shm://%s: all %u slots are taken by live processes\n", c->name, SHM_SLOTS);
    if (rc == 0) {
        c->bell = socket(AF_UNIX, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
        struct sockaddr_un a;
        const socklen_t len = bell_addr(c, c->me, &a);
        if (c->bell < 0 || bind(c->bell, (const struct sockaddr *)&a, len) != 0) {
            fprintf(stderr, "hal_host_net: shm://%s: doorbell of slot %u: %s\n", c->name, c->me, strerror(errno));
            rc = -EIO;
        }
    }
    if (rc != 0) {
        shm_close(c);
        return rc;
    }
    /* What was written before we came is not for us (as a multicast group's past is not). A
       slot claimed after us starts at 0, where we are already; one of a dead owner claimed
       again is read from where its writer marks something for us. Only the slots in use are
       read: each page of the mapping we touch counts in our RSS. */
    const uint32_t hi = slots_in_use(c);
    for (uint32_t i = 0; i < hi; i++)
        for (int k = 0; k < 2; k++)
            c->pos[k][i] = atomic_load(&slot_at(c, i)->ring[k].head);
    shm_slot_clear_subs(c->slot);
    /* Armed from the start: whoever waits for our first datagram (the receiver thread, or the
       GP core polling the doorbell before any take) must be rung for it. */
    atomic_store(&c->slot->armed, 1u);
    *ctx = c;
    return 0;
}

static int shm_publish(void *ctx, const char *channel, const void *data, size_t len, int64_t sender)
{
    shm_ctx_t *c = ctx;
    if (len > SHM_DATAGRAM_MAX)
        return -EIO;
    shm_entry_t e;
    memset(&e, 0, sizeof e);
    e.len = (uint32_t)len;
    e.chan_hash = shm_chan_hash(channel);
    e.sender = sender;
    e.stamp = atomic_fetch_add_explicit(&c->hdr->clock, 1u, memory_order_relaxed);
    memcpy(e.channel, channel, strlen(channel) + 1u);
    const int cls = len > SHM_SMALL_MAX;
    uint64_t at;
    if (shm_ring_write(&c->slot->ring[cls], c->fd, shm_ring_offset(c->me, cls), cls, &e, data, &at) != 0) {
        if (!c->told_full) /* once: each refused publish is counted (tx_rejected) */
            fprintf(stderr, "hal_host_net: shm://%s: writing a datagram of %zu bytes: %s (/dev/shm full? a "
                            "robot's rings take up to %llu MB there); the publishes refused are counted\n", c->name,
                    len, strerror(errno), (unsigned long long)(SHM_RINGS_BYTES >> 20));
        c->told_full = 1;
        return -EIO;
    }
    const uint32_t hi = slots_in_use(c);
    for (uint32_t r = 0; r < hi; r++) {
        shm_slot_t *s = slot_at(c, r);
        if (r == c->me || atomic_load_explicit(&s->owner, memory_order_relaxed) == 0 ||
            !shm_slot_wants(s, e.chan_hash, sender))
            continue;
        _Atomic uint64_t *f = &s->first[cls][c->me];
        if (atomic_load(f) == 0)
            atomic_store(f, at + 1u);
        SHM_FENCE(memory_order_seq_cst);
        if (atomic_load_explicit(&s->armed, memory_order_relaxed) != 0 && atomic_exchange(&s->armed, 0u) != 0)
            ring_bell(c, r);
    }
    return 0;
}

static int shm_subscribe(void *ctx, const char *channel)
{
    shm_ctx_t *c = ctx;
    pthread_mutex_lock(&c->mu);
    const uint32_t n = c->n_chan;
    int rc = n < HAL_HOST_NET_MAX_SUBS ? 0 : -EIO;
    if (rc == 0) {
        memcpy(c->chan[n], channel, strlen(channel) + 1u);
        c->n_chan = n + 1u;
        shm_slot_set_sub(c->slot, n, shm_chan_hash(channel), NULL);
    }
    pthread_mutex_unlock(&c->mu);
    return rc;
}

static int shm_senders(void *ctx, const char *channel, const uint8_t *wanted, uint32_t n_ids)
{
    (void)n_ids; /* bits past the fleet are 0: hal_host_net.c cleared them */
    shm_ctx_t *c = ctx;
    pthread_mutex_lock(&c->mu);
    const uint32_t n = c->n_chan;
    uint32_t i = 0;
    while (i < n && strcmp(c->chan[i], channel) != 0)
        i++;
    if (i < n)
        shm_slot_set_sub(c->slot, i, shm_chan_hash(channel), wanted);
    pthread_mutex_unlock(&c->mu);
    return i < n ? 0 : -EINVAL;
}

/* Moves along writer w's ring cls from where we are (or where it marked the first datagram for
   us, `first`) to the next entry we want, and keeps its header (peeked); or to its head when
   there is none. A lap on the way is a loss, counted. */
static void advance(shm_ctx_t *c, uint32_t w, int cls, uint64_t first)
{
    shm_ring_ctl_t *ctl = &slot_at(c, w)->ring[cls];
    const uint64_t ring = shm_ring_offset(w, cls), cap = shm_ring_cap(cls);
    uint64_t q = c->pos[cls][w] > first ? c->pos[cls][w] : first;
    const uint64_t head = atomic_load(&ctl->head);
    shm_entry_t *e = &c->peek[cls][w];
    c->peeked[cls][w] = 0;
    while (q < head) {
        const shm_read_t r = head - q > cap ? SHM_READ_LAPPED : shm_ring_read(ctl, c->fd, ring, cls, q, e, NULL);
        if (r == SHM_READ_LAPPED) {
            hal_host_net_on_lost(c->n, 1u);
            q = shm_ring_resume(atomic_load(&ctl->head), cls);
        } else if (r == SHM_READ_SKIP) {
            q += cap - q % cap;
        } else if (r != SHM_READ_OK) { /* not an entry: nothing of this ring can be trusted now */
            q = head;
        } else if (shm_slot_wants(c->slot, e->chan_hash, e->sender)) {
            c->peeked[cls][w] = 1;
            break;
        } else {
            q += SHM_ENTRY_BYTES(e->len);
        }
    }
    c->pos[cls][w] = q < head ? q : head;
}

/* Hands the peeked entry of ring (cls, w) over: into take_into's buffer, or to hal_host_net;
   then peeks the next. */
static void take_peeked(shm_ctx_t *c, uint32_t w, int cls)
{
    shm_ring_ctl_t *ctl = &slot_at(c, w)->ring[cls];
    const uint64_t q = c->pos[cls][w];
    shm_entry_t e = c->peek[cls][w];
    const int too_long = c->sink.buf != NULL && e.len > c->sink.cap;
    const shm_read_t r = too_long ? SHM_READ_OK : shm_ring_read(ctl, c->fd, shm_ring_offset(w, cls), cls, q, &e,
                                                                 c->sink.buf != NULL ? c->sink.buf : c->rx);
    if (r == SHM_READ_OK) {
        c->pos[cls][w] = q + SHM_ENTRY_BYTES(e.len);
        if (c->sink.buf == NULL) {
            hal_host_net_on_datagram(c->n, e.channel, c->rx, e.len);
        } else {
            memcpy(c->sink.channel, e.channel, sizeof e.channel);
            c->sink.len = e.len;
            c->sink.got = too_long ? -EMSGSIZE : 1;
        }
    } else { /* overwritten since it was peeked: advance counts the lap */
        c->pos[cls][w] = q;
    }
    advance(c, w, cls, 0u);
}

/* Takes up to *budget wanted datagrams, the oldest first across the rings (the segment's clock:
   the order they were written in, as a socket receives them). Each ring a writer marked for
   us is peeked first. The order matters: the GP core takes 64 datagrams at a time and runs its
   timers in between, and a look that began with every small ring kept 256 robots' chunks
   behind their beacons and RoundCompletes (and one that went round robin split a state's
   chunks across batches), whose timers then asked for chunks already there: hundreds of
   requests a round. Returns 1 when something is left (a budget of 0 only looks). */
static int sweep(shm_ctx_t *c, uint32_t *budget)
{
    const uint32_t hi = slots_in_use(c);
    uint32_t waiting = 0;
    for (int cls = 0; cls < 2; cls++)
        for (uint32_t w = 0; w < hi; w++) {
            _Atomic uint64_t *f = &c->slot->first[cls][w];
            if (atomic_load_explicit(f, memory_order_relaxed) != 0) {
                const uint64_t first = atomic_exchange(f, 0u);
                if (!c->peeked[cls][w] && first != 0)
                    advance(c, w, cls, first - 1u);
            }
            waiting += c->peeked[cls][w];
        }
    for (; waiting > 0 && *budget > 0; (*budget)--) {
        uint32_t bw = 0;
        int bcls = -1;
        for (int cls = 0; cls < 2; cls++)
            for (uint32_t w = 0; w < hi; w++)
                if (c->peeked[cls][w] && (bcls < 0 || c->peek[cls][w].stamp < c->peek[bcls][bw].stamp)) {
                    bw = w;
                    bcls = cls;
                }
        take_peeked(c, bw, bcls);
        waiting -= !c->peeked[bcls][bw];
    }
    return waiting > 0;
}

/* All read: empty the doorbell, arm, and look once more (a writer between our last look and
   the arming rang nobody). sweep's answer. */
static int arm(shm_ctx_t *c, uint32_t *budget)
{
    char b[64];
    while (recv(c->bell, b, sizeof b, MSG_DONTWAIT) > 0) {
    }
    c->rung = 0;
    atomic_store(&c->slot->armed, 1u);
    SHM_FENCE(memory_order_seq_cst);
    return sweep(c, budget);
}

static int shm_take(void *ctx, uint32_t max)
{
    shm_ctx_t *c = ctx;
    uint32_t budget = max;
    int more = sweep(c, &budget);
    if (!more)
        more = arm(c, &budget);
    if (more && !c->rung && !c->takes_first) { /* left short: the doorbell stays readable until we are back */
        atomic_store(&c->slot->armed, 0u);
        ring_bell(c, c->me);
        c->rung = 1;
    }
    return 0;
}

static int shm_take_into(void *ctx, char *channel, void *buf, size_t cap, size_t *len)
{
    shm_ctx_t *c = ctx;
    c->takes_first = 1;
    c->sink.channel = channel;
    c->sink.buf = buf;
    c->sink.cap = cap;
    c->sink.got = 0;
    uint32_t budget = 1;
    if (!sweep(c, &budget) && c->sink.got == 0)
        (void)arm(c, &budget);
    c->sink.buf = NULL;
    *len = c->sink.len;
    return c->sink.got;
}

/* The receiver thread, until the GP core's first wait or receive: it moves nothing. The rings
   hold what arrives meanwhile (a process still starting reads it later, as it would from a
   socket's buffer); moved into the queue, a burst larger than the queue was lost there. */
static int shm_handle(void *ctx, int timeout_ms)
{
    (void)ctx;
    const struct timespec t = {timeout_ms / 1000, (long)(timeout_ms % 1000) * 1000000L};
    nanosleep(&t, NULL);
    return 0;
}

/* The rings hold what waits: every writer's last rounds, more than the queue. */
static int shm_inline_fd(void *ctx, size_t queue_bytes)
{
    (void)queue_bytes;
    return ((shm_ctx_t *)ctx)->bell;
}

const hal_host_net_transport_t hal_host_net_shm = {
    .name = "shm",
    .open = shm_open_url,
    .close = shm_close,
    .publish = shm_publish,
    .subscribe = shm_subscribe,
    .handle = shm_handle,
    .senders = shm_senders,
    .inline_fd = shm_inline_fd,
    .take = shm_take,
    .take_into = shm_take_into,
    .trusted_host = 1,
};
