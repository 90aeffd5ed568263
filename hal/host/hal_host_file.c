/* Whole-or-nothing output files and checked inputs: see hal_host_file.h. */
#include "hal_host_file.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

/* ---- test seam: a disk that fills up after N bytes ------------------------------------- */
static _Atomic long long g_fail_after = -2; /* -2: not read yet, -1: off */
static _Atomic long long g_written;

static long long fail_after(void)
{
    long long v = atomic_load(&g_fail_after);
    if (v == -2) {
        const char *s = getenv("FLEETSIM_FAIL_WRITE_AFTER");
        char *end = NULL;
        long long n = s != NULL ? strtoll(s, &end, 10) : -1;
        v = (s != NULL && end != s && *end == '\0' && n >= 0) ? n : -1;
        atomic_store(&g_fail_after, v);
    }
    return v;
}

/* How many of len bytes the simulated disk still takes. */
static size_t room(size_t len)
{
    long long limit = fail_after();
    if (limit < 0)
        return len;
    long long before = atomic_fetch_add(&g_written, (long long)len);
    if (before >= limit)
        return 0;
    return before + (long long)len <= limit ? len : (size_t)(limit - before);
}

/* ---- the open temporaries, for a signal handler ------------------------------------------
 * An entry is free (0), being filled (1) or holds a path (2). The handler reads an entry
 * without a lock: it copies the path, then checks that the entry still holds a path and that
 * its generation did not move meanwhile, so it never unlinks a path torn between two writers.
 * Lock-free atomics are async-signal-safe (C11 7.14.1.1). */
_Static_assert(ATOMIC_INT_LOCK_FREE == 2, "the signal handler needs lock-free atomics");

typedef struct open_tmp {
    atomic_int state;
    atomic_uint gen;
    char path[PATH_MAX];
} open_tmp_t;

static open_tmp_t g_open[HAL_HOST_FILE_MAX_OPEN];

/* Notes w->tmp before the file exists, so that no temporary file ever exists unnoted. */
static void tmp_note(hal_host_file_t *w)
{
    w->noted = 0;
    for (int i = 0; i < HAL_HOST_FILE_MAX_OPEN; i++) {
        int free_ = 0;
        if (atomic_compare_exchange_strong(&g_open[i].state, &free_, 1)) {
            memcpy(g_open[i].path, w->tmp, sizeof g_open[i].path);
            atomic_store(&g_open[i].state, 2);
            w->noted = i + 1;
            return;
        }
    }
}

/* The temporary file is gone (renamed or removed) or never came to be. */
static void tmp_forget(hal_host_file_t *w)
{
    if (w->noted > 0) {
        open_tmp_t *e = &g_open[w->noted - 1];
        atomic_fetch_add(&e->gen, 1u);
        atomic_store(&e->state, 0);
    }
    w->noted = 0;
    w->tmp[0] = '\0';
}

int hal_host_file_remove_open_temporaries(void)
{
    int removed = 0;
    for (int i = 0; i < HAL_HOST_FILE_MAX_OPEN; i++) {
        open_tmp_t *e = &g_open[i];
        const unsigned gen = atomic_load(&e->gen);
        if (atomic_load(&e->state) != 2)
            continue;
        char p[PATH_MAX];
        for (size_t k = 0; k < sizeof p; k++) /* memcpy is not on every system's list of safe calls */
            if ((p[k] = e->path[k]) == '\0')
                break;
        p[sizeof p - 1] = '\0';
        if (atomic_load(&e->state) == 2 && atomic_load(&e->gen) == gen && unlink(p) == 0)
            removed++;
    }
    return removed;
}

/* ---- paths ------------------------------------------------------------------------------- */
static int split(const char *path, char *dir, size_t dcap, const char **base)
{
    const char *slash = strrchr(path, '/');
    if (slash == NULL) {
        if (dcap < 2)
            return -ENAMETOOLONG;
        strcpy(dir, ".");
        *base = path;
    } else {
        size_t n = slash == path ? 1 : (size_t)(slash - path);
        if (n >= dcap)
            return -ENAMETOOLONG;
        memcpy(dir, path, n);
        dir[n] = '\0';
        *base = slash + 1;
    }
    return **base == '\0' ? -EISDIR : 0; /* "dir/" names a directory, not a file */
}

int hal_host_file_begin(hal_host_file_t *w, const char *path)
{
    if (w == NULL || path == NULL || path[0] == '\0')
        return -EINVAL;
    memset(w, 0, sizeof *w);
    size_t n = strlen(path);
    if (n >= sizeof w->path)
        return -ENAMETOOLONG;
    memcpy(w->path, path, n + 1);
    struct stat st;
    if (stat(path, &st) == 0) {
        if (S_ISDIR(st.st_mode))
            return -EISDIR;
        if (!S_ISREG(st.st_mode))
            return -EEXIST; /* a device, a FIFO, a socket: not ours to replace */
    } else if (errno != ENOENT) {
        return -errno;
    }
    char dir[PATH_MAX];
    const char *base;
    int rc = split(path, dir, sizeof dir, &base);
    if (rc < 0)
        return rc;
    int m = snprintf(w->tmp, sizeof w->tmp, "%s/.%s.%ld%s", dir, base, (long)getpid(),
                     HAL_HOST_FILE_TMP_SUFFIX);
    if (m < 0 || (size_t)m >= sizeof w->tmp) {
        w->tmp[0] = '\0';
        return -ENAMETOOLONG;
    }
    tmp_note(w);
    int fd = open(w->tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0 && errno == ENOENT) {
        /* Every output creates its parents (like mkdir -p). */
        if ((rc = hal_host_file_mkdirs(dir)) < 0) {
            tmp_forget(w);
            return rc;
        }
        fd = open(w->tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    }
    if (fd < 0 && errno == EEXIST) {
        /* Our own leftover (a writer of this process that was not finished): ours to remove. */
        unlink(w->tmp);
        fd = open(w->tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    }
    if (fd < 0) {
        rc = -errno;
        tmp_forget(w);
        return rc;
    }
    w->f = fdopen(fd, "wb");
    if (w->f == NULL) {
        rc = -errno;
        close(fd);
        unlink(w->tmp);
        tmp_forget(w);
        return rc;
    }
    return 0;
}

FILE *hal_host_file_stream(hal_host_file_t *w)
{
    return w != NULL ? w->f : NULL;
}

int hal_host_file_write(hal_host_file_t *w, const void *data, size_t len)
{
    if (w == NULL || w->f == NULL || (data == NULL && len > 0))
        return -EINVAL;
    if (w->err)
        return w->err;
    size_t ok = room(len);
    w->counted += (long long)len;
    if (ok > 0 && fwrite(data, 1, ok, w->f) != ok)
        w->err = errno ? -errno : -EIO;
    else if (ok < len)
        w->err = -ENOSPC;
    return w->err;
}

int hal_host_file_commit(hal_host_file_t *w)
{
    if (w == NULL || w->f == NULL)
        return -EINVAL;
    int rc = w->err;
    errno = 0;
    /* Bytes written straight to the stream (fprintf, libpng) are charged to the test seam
       here, once their total is known. */
    const long pos = ftell(w->f);
    if (rc == 0 && pos > w->counted) {
        const size_t extra = (size_t)(pos - w->counted);
        if (room(extra) < extra)
            rc = -ENOSPC;
    }
    if (rc == 0 && ferror(w->f))
        rc = errno ? -errno : -EIO;
    if (rc == 0 && fflush(w->f) != 0)
        rc = -errno;
    if (rc == 0 && fsync(fileno(w->f)) != 0)
        rc = -errno;
    if (fclose(w->f) != 0 && rc == 0)
        rc = errno ? -errno : -EIO;
    w->f = NULL;
    if (rc == 0 && rename(w->tmp, w->path) != 0)
        rc = -errno;
    if (rc != 0) {
        unlink(w->tmp);
        tmp_forget(w);
        return rc;
    }
    tmp_forget(w);
    char dir[PATH_MAX];
    const char *base;
    if (split(w->path, dir, sizeof dir, &base) == 0) {
        int dfd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
        if (dfd >= 0) {
            (void)fsync(dfd); /* some file systems refuse fsync on a directory: not an error */
            close(dfd);
        }
    }
    return 0;
}

void hal_host_file_abort(hal_host_file_t *w)
{
    if (w == NULL)
        return;
    if (w->f != NULL) {
        fclose(w->f);
        w->f = NULL;
    }
    if (w->tmp[0] != '\0') {
        unlink(w->tmp);
        tmp_forget(w);
    }
}

int hal_host_file_write_all(const char *path, const void *data, size_t len)
{
    hal_host_file_t w;
    int rc = hal_host_file_begin(&w, path);
    if (rc == 0)
        rc = hal_host_file_write(&w, data, len);
    if (rc == 0)
        rc = hal_host_file_commit(&w);
    if (rc != 0)
        hal_host_file_abort(&w);
    return rc;
}

/* `.NAME.PID.fstmp` -> PID, or -1 when the name is not a writer's temporary file. */
static long tmp_pid(const char *name)
{
    size_t n = strlen(name), s = strlen(HAL_HOST_FILE_TMP_SUFFIX);
    if (name[0] != '.' || n <= s + 3 || strcmp(name + n - s, HAL_HOST_FILE_TMP_SUFFIX) != 0)
        return -1;
    const char *end = name + n - s, *p = end;
    while (p > name && p[-1] >= '0' && p[-1] <= '9')
        p--;
    if (p == end || p == name || p[-1] != '.')
        return -1;
    return strtol(p, NULL, 10);
}

int hal_host_file_clean_stale(const char *dir)
{
    DIR *d = opendir(dir);
    if (d == NULL)
        return -errno;
    int removed = 0;
    const long self = (long)getpid();
    for (struct dirent *e; (e = readdir(d)) != NULL;) {
        long pid = tmp_pid(e->d_name);
        if (pid <= 0)
            continue;
        /* A live process (this one included) may be writing it right now. */
        if (pid == self || kill((pid_t)pid, 0) == 0 || errno == EPERM)
            continue;
        char p[PATH_MAX];
        int m = snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
        if (m > 0 && (size_t)m < sizeof p && unlink(p) == 0)
            removed++;
    }
    closedir(d);
    return removed;
}

int hal_host_file_open_read(const char *path, FILE **out)
{
    if (path == NULL || out == NULL)
        return -EINVAL;
    *out = NULL;
    if (strlen(path) >= PATH_MAX)
        return -ENAMETOOLONG;
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return -errno;
    struct stat st;
    if (fstat(fd, &st) != 0 || S_ISDIR(st.st_mode)) {
        int rc = S_ISDIR(st.st_mode) ? -EISDIR : -errno;
        close(fd);
        return rc;
    }
    FILE *f = fdopen(fd, "rb");
    if (f == NULL) {
        int rc = -errno;
        close(fd);
        return rc;
    }
    *out = f;
    return 0;
}

int hal_host_file_mkdirs(const char *dir)
{
    char tmp[PATH_MAX];
    if (dir == NULL || dir[0] == '\0')
        return -EINVAL;
    if (snprintf(tmp, sizeof tmp, "%s", dir) >= (int)sizeof tmp)
        return -ENAMETOOLONG;
    for (char *p = tmp + 1;; p++) {
        const int last = *p == '\0';
        if (!last && *p != '/')
            continue;
        *p = '\0';
        struct stat st;
        if (mkdir(tmp, 0777) != 0) {
            if (errno != EEXIST)
                return -errno;
            if (stat(tmp, &st) != 0)
                return -errno;
            if (!S_ISDIR(st.st_mode))
                return -ENOTDIR;
        }
        if (last)
            break;
        *p = '/';
    }
    return 0;
}

const char *hal_host_file_strerror(int code)
{
    if (code == -EEXIST)
        return "exists and is not a regular file";
    return strerror(code < 0 ? -code : code);
}
