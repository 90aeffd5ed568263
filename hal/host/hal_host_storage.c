/* hal_storage in a directory. A write goes to a temporary file in the same directory, is
 * flushed with fsync, then renamed over the blob (rename is atomic on POSIX file systems),
 * and the directory is fsynced so the rename itself survives a power loss. Temporary names
 * start with '.', which no valid blob name does, so they can never collide with a blob. */
#include "hal_host.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

struct hal_host_storage {
    char *dir;
};

int hal_host_storage_open(const char *dir, hal_host_storage_t **out)
{
    if (dir == NULL || dir[0] == '\0' || out == NULL || strlen(dir) > 3000u)
        return -EINVAL;
    *out = NULL;
    if (mkdir(dir, 0755) != 0 && errno != EEXIST) {
        fprintf(stderr, "hal_host_storage: cannot create '%s': %s\n", dir, strerror(errno));
        return -EIO;
    }
    struct stat st;
    if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode)) {
        fprintf(stderr, "hal_host_storage: '%s' is not a directory\n", dir);
        return -EIO;
    }
    hal_host_storage_t *s = calloc(1, sizeof(*s));
    if (s == NULL)
        return -ENOMEM;
    s->dir = strdup(dir);
    if (s->dir == NULL) {
        free(s);
        return -ENOMEM;
    }
    *out = s;
    return 0;
}

void hal_host_storage_close(hal_host_storage_t *s)
{
    if (s == NULL)
        return;
    free(s->dir);
    free(s);
}

static int errno_to_code(int e)
{
    switch (e) {
    case ENOENT: return -ENOENT;
    case ENOSPC:
    case EDQUOT: return -ENOSPC;
    default: return -EIO;
    }
}

/* Paths are built in caller stack buffers: no allocation per call. */
#define PATH_CAP 4096u

static int make_path(const hal_host_storage_t *s, const char *prefix, const char *name,
                     const char *suffix, char *path)
{
    int n = snprintf(path, PATH_CAP, "%s/%s%s%s", s->dir, prefix, name, suffix);
    return (n < 0 || (unsigned)n >= PATH_CAP) ? -EINVAL : 0;
}

int hal_host_storage_write(hal_host_storage_t *s, const char *name, const void *data, size_t len)
{
    if (s == NULL || !hal_storage_name_valid(name) || (data == NULL && len > 0))
        return -EINVAL;
    char path[PATH_CAP], tmp[PATH_CAP];
    if (make_path(s, "", name, "", path) != 0 || make_path(s, ".", name, ".tmp", tmp) != 0)
        return -EINVAL;
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0)
        return errno_to_code(errno);
    const uint8_t *p = data;
    size_t left = len;
    while (left > 0) {
        ssize_t w = write(fd, p, left);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0) {
            int code = errno_to_code(w < 0 ? errno : EIO);
            close(fd);
            unlink(tmp);
            return code;
        }
        p += w;
        left -= (size_t)w;
    }
    if (fsync(fd) != 0) {
        int code = errno_to_code(errno);
        close(fd);
        unlink(tmp);
        return code;
    }
    if (close(fd) != 0) {
        unlink(tmp);
        return -EIO;
    }
    if (rename(tmp, path) != 0) {
        int code = errno_to_code(errno);
        unlink(tmp);
        return code;
    }
    int dfd = open(s->dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dfd >= 0) {
        (void)fsync(dfd); /* some file systems refuse fsync on a directory: not an error */
        close(dfd);
    }
    return 0;
}

int hal_host_storage_read(hal_host_storage_t *s, const char *name, void *buf, size_t cap,
                          size_t *len)
{
    if (s == NULL || !hal_storage_name_valid(name) || len == NULL || (buf == NULL && cap > 0))
        return -EINVAL;
    char path[PATH_CAP];
    if (make_path(s, "", name, "", path) != 0)
        return -EINVAL;
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return errno_to_code(errno);
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        return -EIO;
    }
    size_t size = (size_t)st.st_size;
    *len = size;
    if (size > cap) {
        close(fd);
        return -EMSGSIZE;
    }
    uint8_t *p = buf;
    size_t got = 0;
    while (got < size) {
        ssize_t r = read(fd, p + got, size - got);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0) {
            close(fd);
            return -EIO; /* the file shrank under us or the read failed */
        }
        got += (size_t)r;
    }
    close(fd);
    return 0;
}

int hal_host_storage_remove(hal_host_storage_t *s, const char *name)
{
    if (s == NULL || !hal_storage_name_valid(name))
        return -EINVAL;
    char path[PATH_CAP];
    if (make_path(s, "", name, "", path) != 0)
        return -EINVAL;
    if (unlink(path) != 0)
        return errno_to_code(errno);
    return 0;
}
