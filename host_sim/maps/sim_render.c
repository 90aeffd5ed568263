/* OSMesa scene renderer: contract in sim_render.h. Legacy GL 1.x on purpose: the scene has
 * a few thousand triangles and this runs on any Mesa without shaders or a display.
 *
 * libOSMesa is loaded at the first render (dlopen), not linked: it pulls in libLLVM and its
 * dependencies, ~46 MB of every process's RSS, while only `host_sim render` draws. The
 * headers still give the types, constants and prototypes; every OSMesa and GL function is
 * called through the table `gl`, whose members have the functions' own names and types. */
#include "sim_render.h"

#include <GL/gl.h>
#include <GL/osmesa.h>
#include <dlfcn.h>
#include <errno.h>
#include <pthread.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sim_grid.h"
#include "sim_palette.h"
#include "sim_shape.h"

#define DEG (3.14159265358979323846 / 180.0)

/* ---- libOSMesa, loaded on first use ------------------------------------------------------ */
#define OSMESA_FUNCS(X) X(OSMesaCreateContextExt) X(OSMesaMakeCurrent) X(OSMesaDestroyContext) \
    X(OSMesaGetProcAddress)
#define GL_FUNCS(X)                                                                              \
    X(glBegin) X(glClear) X(glClearColor) X(glColor3f) X(glColor3fv) X(glColorMaterial)          \
    X(glDisable) X(glEnable) X(glEnd) X(glFinish) X(glFrustum) X(glGetError) X(glLightfv)        \
    X(glLineWidth) X(glLoadIdentity) X(glMatrixMode) X(glMultMatrixd) X(glNormal3d)              \
    X(glNormal3dv) X(glPointSize) X(glPolygonOffset) X(glPopMatrix) X(glPushMatrix) X(glRotated) \
    X(glScaled) X(glTranslated) X(glVertex3d) X(glViewport)

/* __typeof__ (GCC, Clang) of the header's prototype: no reference to the symbol itself. */
#define GL_FIELD(f) __typeof__(&f) f;
static struct {
    OSMESA_FUNCS(GL_FIELD)
    GL_FUNCS(GL_FIELD)
} gl;
#undef GL_FIELD

static pthread_mutex_t gl_mu = PTHREAD_MUTEX_INITIALIZER;
static int gl_loaded; /* under gl_mu; the table is complete once set */

/* Loads the library of `names` (NULL: the defaults) once per process and fills the table.
 * The handle is never closed (the library cannot be unloaded safely: LLVM's and Mesa's
 * static state; LeakSanitizer also needs it mapped to name Mesa's own leak). A failure is
 * not remembered: the next call tries again. */
int sim_render_load(const char *const *names, char *err, size_t errlen)
{
    static const char *const dflt[] = {"libOSMesa.so.8", "libOSMesa.so", NULL};
    char dummy[2];
    if (err == NULL || errlen == 0) {
        err = dummy;
        errlen = sizeof dummy;
    }
    if (names == NULL || names[0] == NULL)
        names = dflt;
    pthread_mutex_lock(&gl_mu);
    if (gl_loaded) {
        pthread_mutex_unlock(&gl_mu);
        return 0;
    }
    void *lib = NULL;
    const char *found = NULL;
    char why[256] = "";
    for (int i = 0; names[i] != NULL && lib == NULL; i++) {
        lib = dlopen(found = names[i], RTLD_NOW | RTLD_LOCAL);
        if (lib == NULL && i == 0) { /* the first name's reason is the one worth telling */
            const char *e = dlerror();
            snprintf(why, sizeof why, "%s", e ? e : "unknown error");
        }
    }
    if (lib == NULL) {
        pthread_mutex_unlock(&gl_mu);
        snprintf(err, errlen, "render: cannot load %s (install libosmesa6): %s", names[0], why);
        return -ENOENT;
    }
    const char *missing = NULL;
    /* dlsym first (Debian's libOSMesa exports every GL function); OSMesaGetProcAddress for a
     * build that only hands them out through it. (dlsym's void * to a function pointer: the
     * conversion POSIX guarantees.) */
#define GL_LOAD_OSMESA(f)                                                                        \
    if (missing == NULL && (gl.f = (__typeof__(&f))dlsym(lib, #f)) == NULL)                      \
        missing = #f;
#define GL_LOAD_GL(f)                                                                            \
    if (missing == NULL && (gl.f = (__typeof__(&f))dlsym(lib, #f)) == NULL &&                    \
        (gl.f = (__typeof__(&f))(void (*)(void))gl.OSMesaGetProcAddress(#f)) == NULL)           \
        missing = #f;
    OSMESA_FUNCS(GL_LOAD_OSMESA)
    GL_FUNCS(GL_LOAD_GL)
#undef GL_LOAD_OSMESA
#undef GL_LOAD_GL
    if (missing != NULL) {
        pthread_mutex_unlock(&gl_mu);
        snprintf(err, errlen, "render: %s has no %s", found, missing);
        return -ENOENT; /* the handle stays open: dlclose of a half-used OSMesa is not safe */
    }
    gl_loaded = 1;
    pthread_mutex_unlock(&gl_mu);
    return 0;
}

sim_render_cfg_t sim_render_default_cfg(void)
{
    sim_render_cfg_t c = {.width = 1024, .height = 768, .fov_deg = 40.0, .azimuth_deg = -90.0,
                          .elevation_deg = 72.0};
    return c;
}

/* An "r, g, b" of 8-bit channels (sim_palette.h's SIM_LIDAR_*) as glColor3f takes it. */
#define RGB_F(c) RGB_F_(c)
#define RGB_F_(r, g, b) (r) / 255.0f, (g) / 255.0f, (b) / 255.0f

/* Robot k's colour (sim_palette.h), as OpenGL takes it. */
static void robot_colour(int k, float col[3])
{
    const uint8_t *c = sim_palette_rgb(k);
    for (int i = 0; i < 3; i++)
        col[i] = c[i] / 255.0f;
}

/* gluLookAt without GLU: column-major view matrix. */
static void look_at(const double eye[3], const double at[3], const double up[3])
{
    double f[3] = {at[0] - eye[0], at[1] - eye[1], at[2] - eye[2]};
    double fl = sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    for (int i = 0; i < 3; i++)
        f[i] /= fl;
    double s[3] = {f[1] * up[2] - f[2] * up[1], f[2] * up[0] - f[0] * up[2], f[0] * up[1] - f[1] * up[0]};
    double sl = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    for (int i = 0; i < 3; i++)
        s[i] /= sl;
    double u[3] = {s[1] * f[2] - s[2] * f[1], s[2] * f[0] - s[0] * f[2], s[0] * f[1] - s[1] * f[0]};
    double m[16] = {s[0], u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0, 0, 0, 0, 1};
    gl.glMultMatrixd(m);
    gl.glTranslated(-eye[0], -eye[1], -eye[2]);
}

static void draw_prism(const sim_poly_t *o, double z0, double z1)
{
    int ccw = sim_shape_area(o) > 0.0;
    int n = o->n;
    gl.glBegin(GL_QUADS);
    for (int k = 0; k < n; k++) {
        const sim_vec2_t *a = &o->p[ccw ? k : n - 1 - k], *b = &o->p[ccw ? (k + 1) % n : (2 * n - 2 - k) % n];
        double dx = b->x - a->x, dy = b->y - a->y, l = hypot(dx, dy);
        if (l <= 0)
            continue;
        gl.glNormal3d(dy / l, -dx / l, 0); /* outward for a CCW outline */
        gl.glVertex3d(a->x, a->y, z0);
        gl.glVertex3d(b->x, b->y, z0);
        gl.glVertex3d(b->x, b->y, z1);
        gl.glVertex3d(a->x, a->y, z1);
    }
    gl.glEnd();
    int tris[SIM_POLY_MAX_POINTS][3];
    int nt = sim_shape_triangulate(o, tris, SIM_POLY_MAX_POINTS);
    gl.glBegin(GL_TRIANGLES);
    gl.glNormal3d(0, 0, 1);
    for (int t = 0; t < nt; t++) {
        int a = tris[t][0], b = tris[t][1], c = tris[t][2]; /* CCW from above */
        gl.glVertex3d(o->p[a].x, o->p[a].y, z1);
        gl.glVertex3d(o->p[b].x, o->p[b].y, z1);
        gl.glVertex3d(o->p[c].x, o->p[c].y, z1);
    }
    gl.glEnd();
}

static void draw_box(double cx, double cy, double cz, double lx, double ly, double lz, double th)
{
    gl.glPushMatrix();
    gl.glTranslated(cx, cy, cz);
    gl.glRotated(th / DEG, 0, 0, 1);
    gl.glScaled(lx * 0.5, ly * 0.5, lz * 0.5);
    static const int faces[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1},
                                    {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
    static const double nrm[6][3] = {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}};
    gl.glBegin(GL_QUADS);
    for (int f = 0; f < 6; f++) {
        gl.glNormal3dv(nrm[f]);
        for (int k = 0; k < 4; k++) {
            int v = faces[f][k];
            gl.glVertex3d((v & 4) ? 1 : -1, (v & 2) ? 1 : -1, (v & 1) ? 1 : -1);
        }
    }
    gl.glEnd();
    gl.glPopMatrix();
}

static void draw_robot(const sim_pose_t *p, const float col[3])
{
    sim_robot_params_t rp = sim_robot_default_params();
    double c = cos(p->theta), s = sin(p->theta);
    double zc = rp.caster_radius + 0.5 * rp.base_height;
    gl.glColor3f(0.25f, 0.25f, 0.28f);
    draw_box(p->x + c * rp.chassis_offset_x, p->y + s * rp.chassis_offset_x, zc, rp.base_length,
             rp.base_width, rp.base_height, p->theta);
    gl.glColor3fv(col); /* top plate in the robot's path colour */
    draw_box(p->x + c * rp.chassis_offset_x, p->y + s * rp.chassis_offset_x,
             rp.caster_radius + rp.base_height + 0.01, 0.6 * rp.base_length, 0.6 * rp.base_width,
             0.02, p->theta);
    gl.glColor3f(0.05f, 0.05f, 0.05f);
    for (int k = -1; k <= 1; k += 2) {
        double oy = k * (0.5 * rp.wheel_separation + 0.015);
        draw_box(p->x - s * oy, p->y + c * oy, rp.wheel_radius, 2 * rp.wheel_radius, 0.018,
                 2 * rp.wheel_radius, p->theta);
    }
    /* Heading mark: a small white box at the front. */
    gl.glColor3f(1, 1, 1);
    double fx = rp.chassis_offset_x + 0.5 * rp.base_length;
    draw_box(p->x + c * fx, p->y + s * fx, rp.caster_radius + rp.base_height + 0.025, 0.03, 0.03,
             0.01, p->theta);
}

static int scene_ok(const sim_render_scene_t *s)
{
    if (s == NULL || s->plan == NULL || s->n_paths < 0 || s->n_robots < 0 ||
        (s->n_paths > 0 && s->paths == NULL) || (s->n_robots > 0 && s->robots == NULL))
        return 0;
    const sim_plan_t *p = s->plan;
    if (!(p->max.x > p->min.x && p->max.y > p->min.y) || !isfinite(p->min.x) || !isfinite(p->max.y))
        return 0;
    if (s->sweep && (s->sweep->n < 1 || s->sweep->ranges == NULL || !(s->sweep->range_max > 0)))
        return 0;
    return 1;
}

int sim_render_rgb(const sim_render_scene_t *scene, const sim_render_cfg_t *cfg, uint8_t *rgb,
                   char *err, size_t errlen)
{
    char dummy[2];
    if (err == NULL || errlen == 0) {
        err = dummy;
        errlen = sizeof dummy;
    }
    if (!scene_ok(scene) || cfg == NULL || rgb == NULL || cfg->width < 16 || cfg->height < 16 ||
        cfg->width > SIM_RENDER_MAX_SIDE || cfg->height > SIM_RENDER_MAX_SIDE ||
        !(cfg->fov_deg > 5 && cfg->fov_deg < 120) || !(cfg->elevation_deg > 5 && cfg->elevation_deg <= 90) ||
        !isfinite(cfg->azimuth_deg)) {
        snprintf(err, errlen, "render: invalid scene or camera (size 16..%d, fov 5..120, elevation 5..90)",
                 SIM_RENDER_MAX_SIDE);
        return -EINVAL;
    }
    int lrc = sim_render_load(NULL, err, errlen);
    if (lrc < 0)
        return lrc;
    const int W = cfg->width, H = cfg->height;
    const sim_plan_t *plan = scene->plan;
    double wall_h = scene->wall_height > 0 ? scene->wall_height : 2.5;
    uint8_t *buf = malloc((size_t)W * (size_t)H * 4);
    if (buf == NULL) {
        snprintf(err, errlen, "render: out of memory");
        return -ENOMEM;
    }
    OSMesaContext ctx = gl.OSMesaCreateContextExt(OSMESA_RGBA, 24, 0, 0, NULL);
    if (ctx == NULL || !gl.OSMesaMakeCurrent(ctx, buf, GL_UNSIGNED_BYTE, W, H)) {
        if (ctx)
            gl.OSMesaDestroyContext(ctx);
        free(buf);
        snprintf(err, errlen, "render: cannot create an OSMesa context");
        return -EIO;
    }

    gl.glViewport(0, 0, W, H);
    gl.glClearColor(0.93f, 0.95f, 0.98f, 1.0f);
    gl.glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    gl.glEnable(GL_DEPTH_TEST);
    gl.glEnable(GL_NORMALIZE);

    /* Camera. */
    double cx = 0.5 * (plan->min.x + plan->max.x), cy = 0.5 * (plan->min.y + plan->max.y);
    double radius = 0.5 * hypot(plan->max.x - plan->min.x, plan->max.y - plan->min.y);
    double aspect = (double)W / (double)H;
    double half_v = 0.5 * cfg->fov_deg * DEG;
    double half_min = aspect >= 1 ? half_v : atan(tan(half_v) * aspect);
    /* The bounding circle is conservative for a rectangle seen at an angle: 0.85 of it
     * fits the plan with a small margin for the usual aspect ratios. */
    double dist = 0.85 * radius / sin(half_min);
    double el = cfg->elevation_deg * DEG, az = cfg->azimuth_deg * DEG;
    /* The world is drawn as it is (x, y in metres, z up: a right-handed frame, so normals and
     * windings stay true). The picture convention (sim_figure.h: y up, as the maps) comes from
     * the camera alone: from the default azimuth -90 (south, -y) with z up, +x runs to the
     * right and +y away from the camera, i.e. up the image; straight down, up is +y. */
    double at[3] = {cx, cy, 0.0};
    double eye[3] = {cx + dist * cos(el) * cos(az), cy + dist * cos(el) * sin(az), dist * sin(el)};
    double up[3] = {0, 0, 1};
    if (cfg->elevation_deg > 89.9) { /* straight down: up is +y */
        up[1] = 1;
        up[2] = 0;
    }
    double znear = fmax(0.05, dist - 2 * radius - wall_h), zfar = dist + 2 * radius + wall_h;
    double top = znear * tan(half_v);
    gl.glMatrixMode(GL_PROJECTION);
    gl.glLoadIdentity();
    gl.glFrustum(-top * aspect, top * aspect, -top, top, znear, zfar);
    gl.glMatrixMode(GL_MODELVIEW);
    gl.glLoadIdentity();
    look_at(eye, at, up);

    /* One directional light from above, a bit from the camera side; strong ambient so the
     * walls facing away stay readable. */
    GLfloat lpos[4] = {(GLfloat)(0.4 * cos(az + 0.6)), (GLfloat)(0.4 * sin(az + 0.6)), 1.0f, 0.0f};
    GLfloat amb[4] = {0.45f, 0.45f, 0.45f, 1.0f}, dif[4] = {0.65f, 0.65f, 0.65f, 1.0f};
    gl.glLightfv(GL_LIGHT0, GL_POSITION, lpos);
    gl.glLightfv(GL_LIGHT0, GL_AMBIENT, amb);
    gl.glLightfv(GL_LIGHT0, GL_DIFFUSE, dif);
    gl.glEnable(GL_LIGHT0);
    gl.glEnable(GL_COLOR_MATERIAL);
    gl.glColorMaterial(GL_FRONT_AND_BACK, GL_AMBIENT_AND_DIFFUSE);
    gl.glEnable(GL_LIGHTING);

    /* Floor over the bounding box (+ margin), rooms tinted just above it. */
    gl.glColor3f(0.78f, 0.78f, 0.76f);
    gl.glBegin(GL_QUADS);
    gl.glNormal3d(0, 0, 1);
    gl.glVertex3d(plan->min.x - 0.5, plan->min.y - 0.5, 0);
    gl.glVertex3d(plan->max.x + 0.5, plan->min.y - 0.5, 0);
    gl.glVertex3d(plan->max.x + 0.5, plan->max.y + 0.5, 0);
    gl.glVertex3d(plan->min.x - 0.5, plan->max.y + 0.5, 0);
    gl.glEnd();
    gl.glEnable(GL_POLYGON_OFFSET_FILL);
    gl.glPolygonOffset(-1, -1);
    for (int r = 0; r < plan->n_rooms; r++) {
        const sim_poly_t *o = &plan->rooms[r].outline;
        int tris[SIM_POLY_MAX_POINTS][3];
        int nt = sim_shape_triangulate(o, tris, SIM_POLY_MAX_POINTS);
        float t = 0.06f * (float)(r % 4);
        gl.glColor3f(0.96f - t, 0.92f - 0.5f * t, 0.84f);
        gl.glBegin(GL_TRIANGLES);
        gl.glNormal3d(0, 0, 1);
        for (int k = 0; k < nt; k++)
            for (int v = 0; v < 3; v++)
                gl.glVertex3d(o->p[tris[k][v]].x, o->p[tris[k][v]].y, 0.0);
        gl.glEnd();
    }
    gl.glDisable(GL_POLYGON_OFFSET_FILL);

    /* Walls. */
    gl.glColor3f(0.82f, 0.84f, 0.90f);
    for (int i = 0; i < plan->n_solids; i++)
        if (plan->solids[i].outline.n >= 3 && plan->solids[i].outline.n <= SIM_POLY_MAX_POINTS)
            draw_prism(&plan->solids[i].outline, 0.0,
                       plan->solids[i].height > 0.0 ? fmin(plan->solids[i].height, wall_h) : wall_h);

    /* Robots. */
    for (int i = 0; i < scene->n_robots; i++) {
        float col[3];
        robot_colour(i, col);
        draw_robot(&scene->robots[i], col);
    }

    /* Unlit overlays: paths and the lidar sweep. */
    gl.glDisable(GL_LIGHTING);
    gl.glLineWidth(2.0f);
    for (int k = 0; k < scene->n_paths; k++) {
        float col[3];
        robot_colour(k, col);
        gl.glColor3fv(col);
        gl.glBegin(GL_LINE_STRIP);
        for (int i = 0; i < scene->paths[k].n; i++)
            gl.glVertex3d(scene->paths[k].p[i].x, scene->paths[k].p[i].y, 0.03);
        gl.glEnd();
        gl.glPointSize(5.0f);
        gl.glBegin(GL_POINTS);
        for (int i = 0; i < scene->paths[k].n; i++)
            gl.glVertex3d(scene->paths[k].p[i].x, scene->paths[k].p[i].y, 0.03);
        gl.glEnd();
    }
    if (scene->sweep) {
        const sim_render_sweep_t *sw = scene->sweep;
        gl.glLineWidth(1.0f);
        gl.glBegin(GL_LINES);
        for (int i = 0; i < sw->n; i++) {
            double a = sw->pose.theta + i * 2 * 3.14159265358979323846 / sw->n;
            int hit = isfinite(sw->ranges[i]) && sw->ranges[i] < sw->range_max;
            double d = hit ? sw->ranges[i] : sw->range_max;
            /* Neutral greys, unlike every robot colour (sim_palette.h). */
            if (hit)
                gl.glColor3f(RGB_F(SIM_LIDAR_HIT_RGB));
            else
                gl.glColor3f(RGB_F(SIM_LIDAR_MISS_RGB));
            gl.glVertex3d(sw->pose.x, sw->pose.y, sw->height);
            gl.glVertex3d(sw->pose.x + d * cos(a), sw->pose.y + d * sin(a), sw->height);
        }
        gl.glEnd();
        gl.glPointSize(4.0f);
        gl.glColor3f(RGB_F(SIM_LIDAR_DOT_RGB));
        gl.glBegin(GL_POINTS);
        for (int i = 0; i < sw->n; i++) {
            double a = sw->pose.theta + i * 2 * 3.14159265358979323846 / sw->n;
            if (isfinite(sw->ranges[i]) && sw->ranges[i] < sw->range_max)
                gl.glVertex3d(sw->pose.x + sw->ranges[i] * cos(a), sw->pose.y + sw->ranges[i] * sin(a),
                           sw->height);
        }
        gl.glEnd();
    }
    gl.glFinish();
    GLenum gerr = gl.glGetError();

    /* OSMesa's buffer has row 0 at the bottom: flip while dropping alpha. */
    for (int y = 0; y < H; y++) {
        const uint8_t *src = buf + (size_t)(H - 1 - y) * (size_t)W * 4;
        uint8_t *dst = rgb + (size_t)y * (size_t)W * 3;
        for (int x = 0; x < W; x++) {
            dst[3 * x] = src[4 * x];
            dst[3 * x + 1] = src[4 * x + 1];
            dst[3 * x + 2] = src[4 * x + 2];
        }
    }
    /* Note: Mesa 22.3's OSMesa keeps ~170 bytes (2 allocations) per context after
     * OSMesaDestroyContext, inside libOSMesa; the render test suppresses that in LSan. */
    gl.OSMesaDestroyContext(ctx);
    free(buf);
    if (gerr != GL_NO_ERROR) {
        snprintf(err, errlen, "render: OpenGL error 0x%x", (unsigned)gerr);
        return -EIO;
    }
    return 0;
}

int sim_render_png(const sim_render_scene_t *scene, const sim_render_cfg_t *cfg, const char *path,
                   char *err, size_t errlen)
{
    char dummy[2];
    if (err == NULL || errlen == 0) {
        err = dummy;
        errlen = sizeof dummy;
    }
    if (cfg == NULL || path == NULL || cfg->width < 16 || cfg->height < 16 ||
        cfg->width > SIM_RENDER_MAX_SIDE || cfg->height > SIM_RENDER_MAX_SIDE) {
        snprintf(err, errlen, "render: invalid image size (16..%d)", SIM_RENDER_MAX_SIDE);
        return -EINVAL;
    }
    uint8_t *rgb = malloc((size_t)cfg->width * (size_t)cfg->height * 3);
    if (rgb == NULL) {
        snprintf(err, errlen, "render: out of memory");
        return -ENOMEM;
    }
    int rc = sim_render_rgb(scene, cfg, rgb, err, errlen);
    if (rc == 0)
        rc = sim_png_write_rgb(path, cfg->width, cfg->height, rgb, err, errlen);
    free(rgb);
    return rc;
}
