/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe relight FACE_DIR -o OUT.png [light] [camera] [material]`: renders a fitted face
 * through sp_face_asset_render (the path `sunprobe evaluate` scores), from any fitted keyframe's
 * view, orbited about the head and dolly-zoomed, under the fitted or a new sun, with the
 * specular and the albedo edited; an RGBA PNG in the capture's encoding, transparent off the head or over
 * a background, or linear OpenEXR / PFM; the light's passes on request.
 */
#include "relight.h"

#include <dirent.h>
#include <errno.h>
#include <getopt.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cmd.h"
#include "common/file_util.h"
#include "common/rigid.h"
#include "sp_config.h"
#include "sunprobe/sp_math.h"

#define MAX_SIZE 8192
#define FILM_HALF_WIDTH_MM 18.0 /* --focal is the 35 mm equivalent: a 36 mm wide frame */

/* Names for --specular-scale NAME=S, in cluster order (FACE_MODEL.md). */
static const char *const cluster_names[SP_RENDER_CLUSTERS] = { "forehead",  "nose",      "left-cheek", "right-cheek",
                                                               "chin",      "lips",      "left-eye",   "right-eye",
                                                               "jaw-neck",  "other" };


static void relight_usage(FILE *out)
{
    fprintf(out,
            "usage: sunprobe relight FACE_DIR -o OUT.png [options]\n\n"
            "Renders the fitted face from a fitted keyframe's view (or around it) under the fitted or a new\n"
            "light, into an RGBA PNG in the capture's encoding, transparent where the head is not.\n"
            "light:\n"
            "  --sun AZ,EL        sun azimuth (from world +x towards +y) and elevation, degrees\n"
            "                     (default: the fitted sun; none if the fit left it out)\n"
            "  --intensity I      sun irradiance (default: the fitted one, 3 if the fit had no sun)\n"
            "  --sun-size DEG     the sun's angular diameter: soft shadows and highlights (default 0: a point)\n"
            "  --fill dir,AZ,EL,I[,R,G,B]  a directional fill light with its own shadow (repeatable, 8)\n"
            "  --fill point,AZ,EL,I[,R,G,B]  a point light 1 m from the head's centre that way, I its\n"
            "                     irradiance at 1 m (falling off as 1/d^2), with its own shadow\n"
            "  --env FILE         the sky: an equirectangular image (OpenEXR, Radiance .hdr, PFM, ... through\n"
            "                     OpenImageIO; z up, row 0 straight up, u = azimuth / 360 from world +x\n"
            "                     towards +y, linear), or a raw 16x32x3 float32 .f32 as env.f32; default: fitted\n"
            "  --env-rotate DEG   turn --env about the vertical by DEG (azimuth)\n"
            "  --exposure E       exposure (default 1)\n"
            "camera:\n"
            "  --view keyframe:N  the view, the face's pose and its light of keyframe N (cameras.json\n"
            "                     \"frames\", 0-based, held-out ones included; default 0)\n"
            "  --orbit AZ,EL      move the camera about the head: AZ degrees about the vertical, EL up\n"
            "  --fov DEG          horizontal field of view, 0.001..178.999 deg; the camera moves so the head\n"
            "                     keeps its size\n"
            "  --focal MM         the same as a 35 mm-equivalent focal length\n"
            "  --size WxH         output size (default: the capture's frame size)\n"
            "  --camera FILE      a camera of its own (JSON: width, height, fx, fy, cx, cy, camera_to_world\n"
            "                     4x4 in the face's world, OpenCV axes; see --save-camera); replaces the\n"
            "                     options above\n"
            "  --save-camera FILE write the camera this render used, in that format\n"
            "background (default: transparent):\n"
            "  --background FILE  the head over a picture (PNG; with OpenImageIO also .exr/.hdr/.pfm, linear, and\n"
            "                     others as sRGB), stretched to the output; the output takes its size unless\n"
            "                     --size, --scale or --camera set one\n"
            "  --background capture:N  composited into keyframe N's own frame of --capture FILE.spcap (the\n"
            "                     view becomes keyframe N's unless --view is given), through the face mask\n"
            "                     with a feathered edge: an edit that reads as the photograph\n"
            "  --capture FILE     the capture the face was fitted from\n"
            "  --scale N          output size as a multiple of the fit resolution instead\n"
            "material:\n"
            "  --specular-scale S         every cluster's specular times S\n"
            "  --specular-scale NAME=S    one cluster: forehead, nose, left-cheek, right-cheek, chin,\n"
            "                             lips, left-eye, right-eye, jaw-neck, other (repeatable)\n"
            "  --albedo-paint PNG         RGBA paint in the albedo's UV layout (FACE_DIR/albedo.png's), sRGB,\n"
            "                             laid over the albedo by its alpha (a PNG without alpha is refused)\n"
            "  --albedo-paint-image PNG,N RGBA paint over keyframe N's frame (its size), projected onto the\n"
            "                             texels that view sees\n"
            "output:\n"
            "  -o OUT             .png (capture encoding, RGBA), .exr (linear RGBA, OpenImageIO) or .pfm (linear RGB)\n"
            "  --supersample N    N x N samples per pixel, 1..4 (default 2)\n"
            "  --panel            one labelled figure instead (thesis Fig. 4.2): the input frame (with --capture),\n"
            "                     the reconstruction, a soft sun, a fill light, sky and sun turned 180 deg,\n"
            "                     two novel views, 24 and 135 mm, shinier skin; from this view and light\n"
            "  --passes DIR       also the light's parts, linear: beauty, diffuse, specular, ambient, visibility,\n"
            "                     normal, albedo, alpha, face (PFM, and OpenEXR where built; DIR/passes.json\n"
            "                     lists them)\n");
}

static int bad_option(const char *opt, const char *val, const char *want)
{
    return sp_opt_bad("relight", opt, val, want);
}

/* S or NAME=S into a->spec_scale; -1 with a message naming the option when bad. */
static int parse_specular(const char *s, relight_args *a)
{
    const char *eq = strchr(s, '=');
    double v;
    if (sp_opt_numbers(eq ? eq + 1 : s, &v, 1) || !(v >= 0.0 && v <= 1000.0))
        return bad_option("specular-scale", s, "S or NAME=S with S in [0, 1000]");
    if (!eq) {
        for (int k = 0; k < SP_RENDER_CLUSTERS; k++)
            a->spec_scale[k] *= v;
        return 0;
    }
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++)
        if (strlen(cluster_names[k]) == (size_t)(eq - s) && !strncmp(s, cluster_names[k], (size_t)(eq - s))) {
            a->spec_scale[k] *= v;
            return 0;
        }
    fprintf(stderr, "sunprobe relight: --specular-scale %s: no cluster '%.*s' (forehead, nose, left-cheek, "
                    "right-cheek, chin, lips, left-eye, right-eye, jaw-neck, other)\n", s, (int)(eq - s), s);
    return -1;
}

/* --fill dir|point,AZ,EL,INTENSITY[,R,G,B] */
static int parse_fill(const char *s, relight_args *a)
{
    static const double lo[6] = { -720, -90, 0, 0, 0, 0 }, hi[6] = { 720, 90, 1e6, 1e3, 1e3, 1e3 };
    fill_light *f = &a->fill[a->n_fill];
    f->point = !strncmp(s, "point,", 6);
    const char *vals = f->point ? s + 6 : (!strncmp(s, "dir,", 4) ? s + 4 : NULL);
    double v[6] = { 0, 0, 0, 1, 1, 1 };
    int ok = a->n_fill < MAX_FILLS && vals && (!sp_opt_numbers(vals, v, 6) || !sp_opt_numbers(vals, v, 3));
    for (int k = 0; ok && k < 6; k++)
        ok = v[k] >= lo[k] && v[k] <= hi[k];
    if (!ok)
        return bad_option("fill", s, "dir|point,AZ,EL,INTENSITY[,R,G,B] (|AZ| <= 720, EL in [-90, 90], intensity "
                                     "in [0, 1e6], R,G,B in [0, 1000], at most 8 fills)");
    f->az = v[0], f->el = v[1], f->intensity = v[2];
    for (int k = 0; k < 3; k++)
        f->rgb[k] = v[3 + k];
    a->n_fill++;
    return 0;
}

/* NAME:N (keyframe:N, capture:N) with N a keyframe number */
static int parse_keyframe(const char *s, const char *prefix, int *out)
{
    size_t n = strlen(prefix);
    return strncmp(s, prefix, n) || sp_opt_int_in(s + n, 0, INT_MAX, out) ? -1 : 0;
}

static int parse_relight(int argc, char **argv, relight_args *a)
{
    static const struct option opts[] = {
        { "help", no_argument, NULL, 'h' },          { "output", required_argument, NULL, 'o' },
        { "sun", required_argument, NULL, 's' },     { "env", required_argument, NULL, 'e' },
        { "intensity", required_argument, NULL, 'i' }, { "exposure", required_argument, NULL, 'x' },
        { "scale", required_argument, NULL, 'S' },   { "view", required_argument, NULL, 'v' },
        { "orbit", required_argument, NULL, 'b' },   { "fov", required_argument, NULL, 'f' },
        { "focal", required_argument, NULL, 'F' },   { "size", required_argument, NULL, 'z' },
        { "specular-scale", required_argument, NULL, 'k' }, { "sun-size", required_argument, NULL, 'a' },
        { "fill", required_argument, NULL, 'l' }, { "env-rotate", required_argument, NULL, 'r' },
        { "background", required_argument, NULL, 'g' }, { "capture", required_argument, NULL, 'c' },
        { "camera", required_argument, NULL, 'C' },  { "save-camera", required_argument, NULL, 'W' },
        { "supersample", required_argument, NULL, 'u' }, { "panel", no_argument, NULL, 'N' },
        { "albedo-paint-image", required_argument, NULL, 'I' }, { "passes", required_argument, NULL, 'P' },  { "albedo-paint", required_argument, NULL, 'p' }, { 0 },
    };
    int c;
    while ((c = getopt_long(argc, argv, "ho:", opts, NULL)) != -1) {
        switch (c) {
        case 'h': relight_usage(stdout); return 1;
        case 'o': a->out = optarg; break;
        case 's':
        {
            double v[2], lo[2] = { -720, -90 }, hi[2] = { 720, 90 };
            if (sp_opt_list("relight", "sun", optarg, 2, lo, hi, v, "AZ,EL in degrees, |AZ| <= 720, EL in [-90, 90]"))
                return -1;
            a->az = v[0], a->el = v[1], a->have_sun = 1;
        }
            break;
        case 'e': a->env = optarg; break;
        case 'i':
            if (sp_opt_double("relight", "intensity", optarg, 0.0, 1e6, &a->intensity))
                return -1;
            break;
        case 'x':
            if (sp_opt_double("relight", "exposure", optarg, 0.0, 1e6, &a->exposure))
                return -1;
            break;
        case 'S':
            if (sp_opt_int("relight", "scale", optarg, 1, 8, &a->scale))
                return -1;
            break;
        case 'v':
            if (parse_keyframe(optarg, "keyframe:", &a->keyframe))
                return bad_option("view", optarg, "keyframe:N with N from 0 to 2147483647");
            a->have_view = 1;
            break;
        case 'g':
            if (strncmp(optarg, "capture:", 8)) {
                a->background_file = optarg;
                break;
            }
            if (parse_keyframe(optarg, "capture:", &a->background_keyframe))
                return bad_option("background", optarg, "capture:N with N from 0 to 2147483647 (and --capture FILE), "
                                                         "or FILE");
            break;
        case 'P': a->passes_dir = optarg; break;
        case 'N': a->panel = 1; break;
        case 'I': {
            const char *comma = strrchr(optarg, ',');
            if (!comma || comma == optarg || sp_opt_int_in(comma + 1, 0, INT_MAX, &a->paint_keyframe))
                return bad_option("albedo-paint-image", optarg, "PNG,N (an RGBA PNG of keyframe N's frame)");
            static char png[4096];
            snprintf(png, sizeof(png), "%.*s", (int)(comma - optarg), optarg);
            a->paint_image = png;
            break;
        }
        case 'u':
            if (sp_opt_int("relight", "supersample", optarg, 1, 4, &a->supersample))
                return -1;
            break;
        case 'p': a->paint = optarg; break;
        case 'c': a->capture = optarg; break;
        case 'C': a->camera_in = optarg; break;
        case 'W': a->camera_out = optarg; break;
        case 'b':
        {
            double v[2], lo[2] = { -360, -nextafter(90.0, 0.0) }, hi[2] = { 360, nextafter(90.0, 0.0) };
            if (sp_opt_list("relight", "orbit", optarg, 2, lo, hi, v, "AZ,EL in degrees, |AZ| <= 360, |EL| < 90"))
                return -1;
            a->orbit_az = v[0], a->orbit_el = v[1], a->have_orbit = 1;
        }
            break;
        case 'f':
            /* a field of view of a denormal degree makes the focal length infinite */
            if (sp_opt_double("relight", "fov", optarg, 0.001, 178.999, &a->fov_deg))
                return -1;
            break;
        case 'F':
            if (sp_opt_double("relight", "focal", optarg, 0.1, 1e5, &a->focal_mm))
                return -1;
            a->fov_deg = 2.0 * atan(FILM_HALF_WIDTH_MM / a->focal_mm) * 180.0 / M_PI;
            break;
        case 'z':
            if (sp_opt_size("relight", "size", optarg, MAX_SIZE, &a->width, &a->height))
                return -1;
            break;
        case 'k':
            if (parse_specular(optarg, a))
                return -1;
            break;
        case 'r':
            if (sp_opt_double("relight", "env-rotate", optarg, -720.0, 720.0, &a->env_rotate))
                return -1;
            break;
        case 'a':
            if (sp_opt_double("relight", "sun-size", optarg, 0.0, 180.0, &a->sun_size))
                return -1;
            break;
        case 'l':
            if (parse_fill(optarg, a))
                return -1;
            break;
        default: return -1;
        }
    }
    if (a->background_keyframe >= 0 && !a->capture) {
        fprintf(stderr, "sunprobe relight: --background capture:%d needs --capture FILE.spcap\n", a->background_keyframe);
        return -1;
    }
    if (a->background_keyframe >= 0 && a->background_file) {
        fprintf(stderr, "sunprobe relight: one --background: capture:%d or %s\n", a->background_keyframe,
                a->background_file);
        return -1;
    }
    if (a->background_keyframe >= 0 && !a->have_view)
        a->keyframe = a->background_keyframe;
    if (a->camera_in && (a->have_view || a->have_orbit || a->fov_deg > 0.0 || a->width || a->scale ||
                         a->background_keyframe >= 0)) {
        fprintf(stderr, "sunprobe relight: --camera gives the whole camera: it does not combine with --view, --orbit, "
                        "--fov, --focal, --size, --scale or --background\n");
        return -1;
    }
    if (a->panel && (a->camera_in || a->passes_dir || a->background_keyframe >= 0 || a->background_file ||
                     !relight_ends_with(a->out, ".png"))) {
        fprintf(stderr, "sunprobe relight: --panel writes one PNG figure of its own views: it does not combine with "
                        "--camera, --passes or --background, and -o must end in .png\n");
        return -1;
    }
    if (optind != argc - 1 || !a->out) {
        fprintf(stderr, "sunprobe relight: expected FACE_DIR and -o OUT.png (see --help)\n");
        return -1;
    }
    a->dir = argv[optind];
    return 0;
}

static int load_json(const char *dir, const char *name, sp_json **out)
{
    char *path = sp_path_join_alloc(dir, name);
    void *buf = NULL;
    size_t n = 0;
    char err[160] = "";
    int ret = path ? sp_read_whole_file(path, 64u << 20, &buf, &n) : -ENOMEM;
    if (!ret && (ret = sp_json_parse(buf, n, out, err, sizeof(err))))
        fprintf(stderr, "sunprobe relight: %s: %s\n", path, err);
    free(buf);
    free(path);
    return ret;
}

/* ---- poses ---- */

typedef sp_rigid pose;

/* Keyframe k's placement of the face model in the fit's world: camera-to-world rotation after the face pose. */
static int keyframe_place(const sp_json *k, pose *place)
{
    double q[4], rv[3];
    pose face = { { 0 }, { 0 } }, c2w = { { 0 }, { 0, 0, 0 } };
    if (sp_json_numbers(sp_json_get(k, "camera_to_world_wxyz"), q, 4) != 4 ||
        sp_json_numbers(sp_json_get(k, "face_rotvec"), rv, 3) != 3 ||
        sp_json_numbers(sp_json_get(k, "face_t"), face.t, 3) != 3)
        return SP_ECORRUPT;
    double qn = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(qn > 0.5 && qn < 2.0) || !isfinite(rv[0] + rv[1] + rv[2] + face.t[0] + face.t[1] + face.t[2]))
        return SP_ECORRUPT;
    sp_quat_to_matrix(sp_quat_normalize((sp_quat){ q[0], q[1], q[2], q[3] }), c2w.R);
    sp_quat_to_matrix(sp_quat_from_rotvec((sp_vec3){ rv[0], rv[1], rv[2] }), face.R);
    *place = sp_rigid_mul(&c2w, &face);
    return 0;
}

/* Rotation by angle a (radians) about the unit axis u, row-major. */
static void axis_rotation(const double u[3], double a, double R[9])
{
    double c = cos(a), s = sin(a), C = 1.0 - c;
    double m[9] = { c + u[0] * u[0] * C,        u[0] * u[1] * C - u[2] * s, u[0] * u[2] * C + u[1] * s,
                    u[1] * u[0] * C + u[2] * s, c + u[1] * u[1] * C,        u[1] * u[2] * C - u[0] * s,
                    u[2] * u[0] * C - u[1] * s, u[2] * u[1] * C + u[0] * s, c + u[2] * u[2] * C };
    memcpy(R, m, sizeof(m));
}


/* Direction towards a light at azimuth (from world +x towards +y) and elevation, degrees. */
static void sun_vector(double az_deg, double el_deg, double d[3])
{
    double az = az_deg * M_PI / 180.0, el = el_deg * M_PI / 180.0;
    d[0] = cos(el) * cos(az);
    d[1] = cos(el) * sin(az);
    d[2] = sin(el);
}

/* Vertex i of the asset where view v puts it in the world. */
static void world_point(const sp_face_asset *fa, const sp_face_view *v, uint32_t i, double w[3])
{
    const float *pf = fa->mesh.positions + (size_t)i * 3;
    double p[3] = { pf[0], pf[1], pf[2] };
    for (int k = 0; k < 3; k++)
        w[k] = v->asset_to_world[k * 4] * p[0] + v->asset_to_world[k * 4 + 1] * p[1] +
               v->asset_to_world[k * 4 + 2] * p[2] + v->asset_to_world[k * 4 + 3];
}

/*
 * --camera FILE: {"width", "height", "fx", "fy", "cx", "cy", "camera_to_world": 4 rows of 4} in the face's
 * world (the one keyframe 0's camera is at the origin of; OpenCV camera axes: x right, y down, z forward).
 * Every field is checked, and named when it is wrong.
 */
static const char *camera_from_json(const sp_json *root, sp_face_view *v)
{
    double w = sp_json_number(sp_json_get(root, "width"), 0), h = sp_json_number(sp_json_get(root, "height"), 0);
    double K[4] = { sp_json_number(sp_json_get(root, "fx"), NAN), sp_json_number(sp_json_get(root, "fy"), NAN),
                    sp_json_number(sp_json_get(root, "cx"), NAN), sp_json_number(sp_json_get(root, "cy"), NAN) };
    double M[16];
    const sp_json *rows = sp_json_get(root, "camera_to_world");
    int nrows = 0;
    while (nrows < 4 && sp_json_numbers(sp_json_at(rows, (size_t)nrows), M + 4 * nrows, 4) == 4)
        nrows++;
    if (!(w >= 1 && w <= MAX_SIZE && h >= 1 && h <= MAX_SIZE && w == floor(w) && h == floor(h)))
        return "width and height must be whole numbers from 1 to 8192";
    if (!(K[0] > 0.0 && K[0] < 1e6 && K[1] > 0.0 && K[1] < 1e6))
        return "fx and fy must be in (0, 1e6) pixels";
    if (!(fabs(K[2]) < 1e6 && fabs(K[3]) < 1e6))
        return "cx and cy must be finite pixels (|c| < 1e6)";
    if (nrows != 4 || sp_json_at(rows, 4))
        return "camera_to_world must be 4 rows of 4 numbers";
    double R[9], Rt[9], RRt[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            R[i * 3 + j] = M[i * 4 + j], Rt[j * 3 + i] = M[i * 4 + j];
    sp_mat3_mul(R, Rt, RRt);
    double det = R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6]) +
                 R[2] * (R[3] * R[7] - R[4] * R[6]);
    double off = 0.0;
    for (int i = 0; i < 9; i++)
        off = fmax(off, fabs(RRt[i] - (i % 4 == 0 ? 1.0 : 0.0)));
    if (!(off < 1e-3) || !(det > 0.0))
        return "camera_to_world's 3x3 part must be a rotation (orthonormal within 1e-3, determinant +1)";
    if (!(fabs(M[3]) < 1e6 && fabs(M[7]) < 1e6 && fabs(M[11]) < 1e6))
        return "camera_to_world's translation must be finite metres (|t| < 1e6)";
    if (M[12] != 0.0 || M[13] != 0.0 || M[14] != 0.0 || M[15] != 1.0)
        return "camera_to_world's last row must be 0 0 0 1";
    pose c2w = { .t = { M[3], M[7], M[11] } }, w2c;
    memcpy(c2w.R, R, sizeof(R));
    w2c = sp_rigid_inv(&c2w);
    memcpy(v->camera.R, w2c.R, sizeof(w2c.R));
    memcpy(v->camera.t, w2c.t, sizeof(w2c.t));
    v->camera.fx = K[0], v->camera.fy = K[1], v->camera.cx = K[2], v->camera.cy = K[3];
    v->width = (int)w;
    v->height = (int)h;
    return NULL;
}

static int read_camera(const relight_args *a, sp_face_view *v)
{
    sp_json *root = NULL;
    char err[160] = "";
    void *buf = NULL;
    size_t n = 0;
    int ret = sp_read_whole_file(a->camera_in, 1u << 20, &buf, &n);
    if (ret) {
        fprintf(stderr, "sunprobe relight: --camera %s: %s\n", a->camera_in, sp_strerror(ret));
        return sp_exit_for_error(ret);
    }
    ret = sp_json_parse(buf, n, &root, err, sizeof(err));
    free(buf);
    if (ret) {
        fprintf(stderr, "sunprobe relight: --camera %s: %s\n", a->camera_in, err);
        return SP_EXIT_BAD_INPUT;
    }
    const char *bad = camera_from_json(root, v);
    sp_json_free(root);
    if (bad) {
        fprintf(stderr, "sunprobe relight: --camera %s: %s\n", a->camera_in, bad);
        return SP_EXIT_BAD_INPUT;
    }
    return 0;
}

/* --save-camera FILE: the view's camera in --camera's format, written atomically. */
static int save_camera(const relight_args *a, const sp_face_view *v)
{
    pose w2c, c2w;
    memcpy(w2c.R, v->camera.R, sizeof(w2c.R));
    memcpy(w2c.t, v->camera.t, sizeof(w2c.t));
    c2w = sp_rigid_inv(&w2c);
    const double *R = c2w.R, *C = c2w.t;
    char text[1024];
    int n = snprintf(text, sizeof(text),
                     "{\"width\": %d, \"height\": %d, \"fx\": %.17g, \"fy\": %.17g, \"cx\": %.17g, \"cy\": %.17g,\n"
                     " \"camera_to_world\": [[%.17g, %.17g, %.17g, %.17g], [%.17g, %.17g, %.17g, %.17g],\n"
                     "                     [%.17g, %.17g, %.17g, %.17g], [0, 0, 0, 1]]}\n",
                     v->width, v->height, v->camera.fx, v->camera.fy, v->camera.cx, v->camera.cy, R[0], R[1], R[2],
                     C[0], R[3], R[4], R[5], C[1], R[6], R[7], R[8], C[2]);
    int ret = n > 0 && (size_t)n < sizeof(text) ? sp_write_whole_file_atomic(a->camera_out, text, (size_t)n) : -ENOMEM;
    if (ret) {
        return sp_cmd_failf("relight", ret, "--save-camera %s", a->camera_out);
    }
    return 0;
}

/*
 * What the fit observed of the model the asset was fitted with (the default one or the generic head): its
 * face_mask skin and the eyeballs, per vertex (c->fit_mask); NULL when neither model has the asset's topology.
 */
static const uint8_t *face_mask_for(relight_ctx *c)
{
    for (int generic = 0; generic < 2 && !c->fit_mask; generic++) {
        if ((c->have_model = (generic ? sp_face_model_generic(&c->model) : sp_face_model_load_default(&c->model)) == 0) &&
            c->model.mesh.n_vertices == c->fa.mesh.n_vertices && (c->fit_mask = malloc(c->fa.mesh.n_vertices))) {
            for (uint32_t i = 0; i < c->fa.mesh.n_vertices; i++)
                c->fit_mask[i] = c->model.face_mask[i] || (c->model.part && c->model.part[i] == SP_FACE_PART_EYE);
            return c->fit_mask;
        }
        if (c->have_model)
            sp_face_model_free(&c->model);
        c->have_model = 0;
    }
    return c->fit_mask;
}

/*
 * Keyframe kf's face as the fit rendered it, into c->fa.mesh: the model (when one of this build has the
 * asset's topology) with the fit's identity and scale and the keyframe's expression and pose, turned into
 * the world by its camera. 1 when done, 0 when the rigidly moved asset must do (no such model or data).
 */
static int keyframe_mesh(relight_ctx *c, const sp_json *kf)
{
    const sp_face_model *m = face_mask_for(c) ? &c->model : NULL;
    if (!m || !m->n_exp || !m->n_id)
        return 0;
    double *id = malloc(sizeof(double) * m->n_id), *ex = malloc(sizeof(double) * m->n_exp), q[4];
    double *pos = malloc(sizeof(double) * 3 * m->mesh.n_vertices), R[9];
    sp_face_params p;
    sp_face_params_init(&p);
    int ok = id && ex && pos &&
             sp_json_numbers(sp_json_get(c->manifest, "identity"), id, m->n_id) == m->n_id &&
             sp_json_numbers(sp_json_get(kf, "expression"), ex, m->n_exp) == m->n_exp &&
             !sp_json_at(sp_json_get(c->manifest, "identity"), m->n_id) && /* not another model's longer basis */
             !sp_json_at(sp_json_get(kf, "expression"), m->n_exp) &&
             sp_json_numbers(sp_json_get(kf, "face_rotvec"), p.rotvec, 3) == 3 &&
             sp_json_numbers(sp_json_get(kf, "face_t"), p.t, 3) == 3 &&
             sp_json_numbers(sp_json_get(kf, "camera_to_world_wxyz"), q, 4) == 4;
    p.id = id, p.exp = ex, p.s = sp_json_number(sp_json_get(c->manifest, "scale"), 1.0);
    ok = ok && sp_face_model_eval(m, &p, pos) == 0;
    if (ok) {
        sp_quat_to_matrix(sp_quat_normalize((sp_quat){ q[0], q[1], q[2], q[3] }), R);
        for (uint32_t i = 0; i < m->mesh.n_vertices; i++)
            for (int r = 0; r < 3; r++)
                c->fa.mesh.positions[(size_t)i * 3 + (size_t)r] =
                    (float)(R[r * 3] * pos[i * 3] + R[r * 3 + 1] * pos[i * 3 + 1] + R[r * 3 + 2] * pos[i * 3 + 2]);
    }
    free(id);
    free(ex);
    free(pos);
    return ok;
}

/*
 * The view: keyframe N (the face placed in the world as it was then, that camera), then the orbit
 * about the head's centre and the dolly zoom, then the output size. Returns 0 or a message'd error.
 */
static int set_view(relight_ctx *c, sp_face_view *v)
{
    const relight_args *a = c->a;
    sp_face_view_init(v, &c->fa);
    const sp_json *frames = sp_json_get(c->cams, "frames");
    size_t n_frames = 0;
    while (sp_json_at(frames, n_frames))
        n_frames++;
    if (a->keyframe > 0 && (size_t)a->keyframe >= n_frames) {
        fprintf(stderr, "sunprobe relight: --view keyframe:%d: %s/cameras.json has %zu keyframes (0..%zu)\n",
                a->keyframe, a->dir, n_frames, n_frames ? n_frames - 1 : 0);
        return SP_EXIT_USAGE;
    }
    const sp_json *kf = sp_json_at(frames, (size_t)a->keyframe);
    double expo = sp_json_number(sp_json_get(kf, "exposure"), 1.0); /* absent before the fit wrote it */
    c->kf_exposure = expo > 0.0 && expo < 1e6 ? expo : 1.0;
    double ppp = sp_json_number(sp_json_get(kf, "capture_pixels_per_pixel"), 1.0);
    ppp = ppp >= 1.0 && ppp <= 64.0 ? ppp : 1.0;
    int fit_w = c->fa.width, fit_h = c->fa.height;
    int evaluated = keyframe_mesh(c, kf); /* else the asset as the first training keyframe placed it, moved */
    if (a->keyframe > 0) {
        const sp_json *ref = NULL;
        for (size_t i = 0; i < n_frames && !ref; i++) {
            const sp_json *held = sp_json_get(sp_json_at(frames, i), "heldout");
            if (!(held && held->type == SP_JSON_BOOL && held->number != 0.0))
                ref = sp_json_at(frames, i);
        }
        pose p0, pn;
        double K[4];
        if (!ref || keyframe_place(ref, &p0) || keyframe_place(kf, &pn) ||
            sp_json_numbers(sp_json_get(kf, "intrinsics"), K, 4) != 4 || !(K[0] > 0.0 && K[1] > 0.0)) {
            fprintf(stderr, "sunprobe relight: %s/cameras.json: frames[%d] has no usable camera_to_world_wxyz, "
                            "face_rotvec, face_t and intrinsics\n", a->dir, a->keyframe);
            return SP_EXIT_BAD_INPUT;
        }
        pose inv0 = sp_rigid_inv(&p0), a2w = sp_rigid_mul(&pn, &inv0);
        for (int i = 0; i < 3 && !evaluated; i++) { /* an evaluated mesh is already where keyframe N had it */
            for (int j = 0; j < 3; j++)
                v->asset_to_world[i * 4 + j] = a2w.R[i * 3 + j];
            v->asset_to_world[i * 4 + 3] = a2w.t[i];
        }
        double q[4];
        sp_json_numbers(sp_json_get(kf, "camera_to_world_wxyz"), q, 4);
        double c2w[9];
        sp_quat_to_matrix(sp_quat_normalize((sp_quat){ q[0], q[1], q[2], q[3] }), c2w);
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                v->camera.R[i * 3 + j] = c2w[j * 3 + i];
        memset(v->camera.t, 0, sizeof(v->camera.t));
        v->camera.fx = K[0], v->camera.fy = K[1], v->camera.cx = K[2], v->camera.cy = K[3];
        fit_w = (int)sp_json_number(sp_json_get(kf, "width"), fit_w);
        fit_h = (int)sp_json_number(sp_json_get(kf, "height"), fit_h);
    }
    /* the head's centre in the world: the mesh's centroid where this view puts it */
    double centre[3] = { 0, 0, 0 };
    for (uint32_t i = 0; i < c->fa.mesh.n_vertices; i++) {
        double w[3];
        world_point(&c->fa, v, i, w);
        for (int k = 0; k < 3; k++)
            centre[k] += w[k] / (double)c->fa.mesh.n_vertices;
    }
    memcpy(c->centre, centre, sizeof(centre));
    /* camera centre C = -R^T t and camera-to-world rotation R^T */
    double Rt[9], C[3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            Rt[i * 3 + j] = v->camera.R[j * 3 + i];
    sp_mat3_apply(Rt, v->camera.t, C);
    for (int k = 0; k < 3; k++)
        C[k] = -C[k];
    if (a->have_orbit) {
        static const double up[3] = { 0, 0, 1 }; /* the fit's world is z up */
        double off[3] = { C[0] - centre[0], C[1] - centre[1], C[2] - centre[2] }, h[3], Raz[9], Rel[9], M[9];
        h[0] = off[1] * up[2] - off[2] * up[1], h[1] = off[2] * up[0] - off[0] * up[2], h[2] = off[0] * up[1] - off[1] * up[0];
        double hn = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
        if (hn > 1e-9) {
            for (int k = 0; k < 3; k++)
                h[k] /= hn;
            axis_rotation(h, a->orbit_el * M_PI / 180.0, Rel);
        } else { /* looking straight down or up: no horizontal axis to raise the camera about */
            memcpy(Rel, (double[9]){ 1, 0, 0, 0, 1, 0, 0, 0, 1 }, sizeof(Rel));
        }
        axis_rotation(up, a->orbit_az * M_PI / 180.0, Raz);
        sp_mat3_mul(Raz, Rel, M);
        double moved[3], Rn[9];
        sp_mat3_apply(M, off, moved);
        for (int k = 0; k < 3; k++)
            C[k] = centre[k] + moved[k];
        sp_mat3_mul(M, Rt, Rn); /* the new camera-to-world */
        memcpy(Rt, Rn, sizeof(Rt));
    }
    /* output size and intrinsics: the keyframe's fit-resolution camera scaled up, square pixels kept */
    int W = a->width ? a->width : (a->scale ? fit_w * a->scale : (int)lround(fit_w * ppp));
    int H = a->width ? a->height : (a->scale ? fit_h * a->scale : (int)lround(fit_h * ppp));
    if (c->bg_is_capture) { /* the frame's size; the fit's window scaled into it and moved to its origin */
        W = (int)c->bg_w;
        H = (int)c->bg_h;
        v->camera.fx *= ppp;
        v->camera.fy *= ppp;
        v->camera.cx = (v->camera.cx + 0.5) * ppp - 0.5 + c->bg_crop[0];
        v->camera.cy = (v->camera.cy + 0.5) * ppp - 0.5 + c->bg_crop[1];
        fit_w = W;
        fit_h = H;
    }
    W = W < 1 ? 1 : (W > MAX_SIZE ? MAX_SIZE : W);
    H = H < 1 ? 1 : (H > MAX_SIZE ? MAX_SIZE : H);
    double sx = (double)W / fit_w, sy = (double)H / fit_h;
    double fx = v->camera.fx * sx, fy = v->camera.fy * sx;
    v->camera.cx = (v->camera.cx + 0.5) * sx - 0.5;
    v->camera.cy = (v->camera.cy + 0.5) * sy - 0.5;
    if (a->fov_deg > 0.0) {
        /* dolly zoom: the camera backs away along its axis until the head's depth has grown with the focal
           length, so the head keeps its size and its place in the picture */
        double fx_new = 0.5 * W / tan(0.5 * a->fov_deg * M_PI / 180.0), k = fx_new / fx;
        double fwd[3] = { Rt[2], Rt[5], Rt[8] }, depth = 0.0, radius = 0.0;
        for (int i = 0; i < 3; i++)
            depth += fwd[i] * (centre[i] - C[i]);
        for (int i = 0; i < 3; i++)
            C[i] -= (k - 1.0) * depth * fwd[i];
        for (uint32_t i = 0; i < c->fa.mesh.n_vertices; i++) {
            double w[3];
            world_point(&c->fa, v, i, w);
            radius = fmax(radius, sqrt((w[0] - centre[0]) * (w[0] - centre[0]) + (w[1] - centre[1]) * (w[1] - centre[1]) +
                                       (w[2] - centre[2]) * (w[2] - centre[2])));
        }
        if (k * depth < radius)
            fprintf(stderr, "sunprobe relight: warning: at this focal length the camera is %.2f m from the head's "
                            "centre, inside its %.2f m radius\n", k * depth, radius);
        fy *= k;
        fx = fx_new;
    }
    v->camera.fx = fx;
    v->camera.fy = fy;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            v->camera.R[i * 3 + j] = Rt[j * 3 + i];
    double RC[3];
    sp_mat3_apply(v->camera.R, C, RC);
    for (int k = 0; k < 3; k++)
        v->camera.t[k] = -RC[k];
    v->width = W;
    v->height = H;
    return 0;
}

static void set_light(relight_ctx *c, sp_face_view *v)
{
    const relight_args *a = c->a;
    int fitted_sun = !(c->fa.left_out & SP_FACE_LEFT_OUT_SUN) && c->fa.sun_intensity > 0.0;
    if (a->have_sun) {
        sun_vector(a->az, a->el, v->sun_dir);
        v->sun_intensity = a->intensity > 0.0 ? a->intensity : (fitted_sun ? c->fa.sun_intensity : 3.0);
    } else {
        v->sun_intensity = fitted_sun ? (a->intensity > 0.0 ? a->intensity : c->fa.sun_intensity) : 0.0;
    }
    /* the keyframe's own exposure (keyframe 0's under --camera), so its view looks as its photograph did */
    v->exposure = (a->exposure > 0.0 ? a->exposure : 1.0) * c->kf_exposure;
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++) /* from the fitted values, so views can be made again */
        c->fa.ks[k] = c->ks_fitted[k] * a->spec_scale[k];
}

/* The sums the lights are added into: the beauty always, every pass for --passes. */
typedef struct light_sums {
    float *sum[PASS_COUNT], *tmp[PASS_COUNT];
    float *cover, *face; /* the head's and the face's coverage, from the base render */
    int all;
} light_sums;

enum render_kind { RENDER_BASE, RENDER_FILL };

/*
 * Adds one render of view v: the beauty and the diffuse and specular passes (scaled per channel by rgb,
 * NULL = white); the sky's ambient, the normal, albedo, the sun's visibility (times w) and the coverages
 * from the base render.
 */
static int add_render(relight_ctx *c, const sp_face_view *v, enum render_kind kind, double w, const double *rgb,
                      light_sums *ls)
{
    size_t n = (size_t)v->width * (size_t)v->height;
    float *const *t = ls->tmp;
    sp_face_passes p = { .radiance = t[PASS_BEAUTY], .mask = kind == RENDER_BASE ? ls->face : NULL,
                         .coverage = kind == RENDER_BASE ? ls->cover : NULL };
    if (ls->all)
        p.diffuse = t[PASS_DIFFUSE], p.specular = t[PASS_SPECULAR], p.ambient = t[PASS_AMBIENT],
        p.visibility = t[PASS_VISIBILITY], p.normal = t[PASS_NORMAL], p.albedo = t[PASS_ALBEDO];
    int ret = sp_face_asset_render_passes(&c->fa, v, &p);
    for (int k = 0; !ret && k < (ls->all ? PASS_COUNT : 1); k++) {
        int ch = relight_pass_channels(k);
        float *s = ls->sum[k];
        const float *x = k == PASS_ALPHA ? ls->cover : (k == PASS_FACE ? ls->face : t[k]);
        int add = k <= PASS_SPECULAR, base_only = k == PASS_AMBIENT || k >= PASS_NORMAL;
        if (k == PASS_VISIBILITY && kind == RENDER_BASE) {
            for (size_t i = 0; i < n; i++)
                s[i] += (float)(fabs(w) * (double)x[i]);
        } else if (add || (base_only && kind == RENDER_BASE)) {
            for (size_t i = 0; i < n * (size_t)ch; i++)
                s[i] += (float)((double)x[i] * (rgb && ch == 3 ? rgb[i % 3] : 1.0));
        }
    }
    return ret;
}

/*
 * Light is additive: the sky with the sun in one render (a sun disk of --sun-size is the renderer's soft
 * sun: one shadow map, soft shadows and highlights), then every fill with its own shadow and colour, as a
 * sun under a black sky; in linear light.
 */
static int render_lights(relight_ctx *c, const sp_face_view *v0, light_sums *ls)
{
    const relight_args *a = c->a;
    float *dark = calloc(SP_RENDER_ENV_FLOATS, sizeof(float));
    int ret = dark ? 0 : -ENOMEM;
    sp_face_view v = *v0;
    v.sun_angular_radius = 0.5 * a->sun_size * M_PI / 180.0;
    if (!ret)
        ret = add_render(c, &v, RENDER_BASE, 1.0, NULL, ls);
    v.env = dark;
    v.sun_angular_radius = 0.0;
    memcpy(v.env_to_world, (double[9]){ 1, 0, 0, 0, 1, 0, 0, 0, 1 }, sizeof(v.env_to_world));
    for (int f = 0; !ret && f < a->n_fill; f++) {
        if (!(a->fill[f].intensity > 0.0))
            continue; /* no light, nothing to add */
        sun_vector(a->fill[f].az, a->fill[f].el, v.sun_dir);
        v.sun_intensity = a->fill[f].intensity;
        v.sun_is_point = a->fill[f].point;
        for (int k = 0; k < 3; k++) /* 1 m from the head's centre */
            v.sun_position[k] = c->centre[k] + v.sun_dir[k];
        ret = add_render(c, &v, RENDER_FILL, 0.0, a->fill[f].rgb, ls);
    }
    free(dark);
    return ret;
}

static void free_sums(light_sums *ls)
{
    for (int k = 0; k < PASS_COUNT; k++) {
        free(ls->sum[k]);
        free(ls->tmp[k]);
    }
    free(ls->cover);
    free(ls->face);
}

/* ls (all set to 0 but .all) gets its buffers and every light of view v; 0 or a negative error. */
static int render_sums(relight_ctx *c, const sp_face_view *v, light_sums *ls)
{
    size_t n = (size_t)v->width * (size_t)v->height;
    int ret = 0;
    for (int k = 0; k < (ls->all ? PASS_COUNT : 1) && !ret; k++) {
        size_t m = n * (size_t)relight_pass_channels(k);
        ls->sum[k] = calloc(m, sizeof(float));
        ls->tmp[k] = malloc(sizeof(float) * m);
        ret = ls->sum[k] && ls->tmp[k] ? 0 : -ENOMEM;
    }
    ls->cover = ret ? NULL : malloc(sizeof(float) * n);
    ls->face = ret ? NULL : malloc(sizeof(float) * n);
    return ls->cover && ls->face ? render_lights(c, v, ls) : -ENOMEM;
}

/* Renders every light of view v, composites and writes -o (and --passes into pd->path); 0 or an error. */
static int render_and_write(relight_ctx *c, sp_face_view *v, const sp_partial *pd)
{
    size_t n = (size_t)v->width * (size_t)v->height;
    light_sums ls = { .all = c->a->passes_dir != NULL };
    int ret = render_sums(c, v, &ls);
    if (!ret && ls.all)
        ret = relight_write_passes(pd->path, ls.sum, v->width, v->height, v->exposure);
    if (!ret && c->bg) {
        relight_composite(c, ls.sum[PASS_BEAUTY], c->bg_is_capture ? ls.face : ls.cover, v->width, v->height,
                          v->exposure);
        for (size_t i = 0; i < n; i++)
            ls.cover[i] = 1.0f; /* a photograph: opaque */
    }
    if (!ret && sp_cmd_stop_signal) /* Ctrl-C while rendering: OUT as it was, the passes' partial dir removed */
        ret = -ECANCELED;
    if (!ret)
        ret = relight_write_image(c, ls.sum[PASS_BEAUTY], ls.cover, v->width, v->height, v->exposure);
    free_sums(&ls);
    return ret;
}

/* The face directory, its sky, edits and backgrounds read; 0 or an exit code (message printed). */
static int read_inputs(relight_ctx *c)
{
    relight_args *a = c->a;
    int ret = sp_face_dir_read(&c->fa, a->dir);
    if (ret) {
        fprintf(stderr, "sunprobe relight: %s is not a readable face directory: %s\n", a->dir, sp_strerror(ret));
        return sp_exit_for_error(ret == -ENOENT ? SP_EFORMAT : ret);
    }
    memcpy(c->ks_fitted, c->fa.ks, sizeof(c->ks_fitted));
    if (a->env && (ret = relight_read_env(a, c->fa.env)))
        return sp_exit_for_error(ret);
    if ((ret = load_json(a->dir, "cameras.json", &c->cams)) || (ret = load_json(a->dir, "manifest.json", &c->manifest)))
        return sp_cmd_fail("relight", ret, a->dir);
    const char *transfer = sp_json_string(sp_json_get(c->manifest, "capture_transfer"), NULL);
    c->srgb = transfer && !strcmp(transfer, "srgb");
    if (a->paint && (ret = relight_paint(c)))
        return ret;
    if (a->background_keyframe >= 0 && (ret = relight_read_background(c)))
        return ret;
    if (a->background_file && (ret = relight_read_background_file(c)))
        return ret;
    if (a->background_file)
        c->srgb = 1; /* the picture's encoding, not the capture's */
    if (a->background_file && !a->width && !a->scale && !a->camera_in) { /* the picture's size */
        a->width = c->bg_w > MAX_SIZE ? MAX_SIZE : (int)c->bg_w;
        a->height = c->bg_h > MAX_SIZE ? MAX_SIZE : (int)c->bg_h;
    }
    return 0;
}

/* 1 when --passes may go to dir: absent, empty, or an earlier passes directory (it holds passes.json). */
static int passes_dir_usable(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return errno == ENOENT;
    int entries = 0;
    for (struct dirent *e; (e = readdir(d));)
        entries += strcmp(e->d_name, ".") && strcmp(e->d_name, "..");
    closedir(d);
    char *marker = sp_path_join_alloc(dir, "passes.json");
    int ours = marker && sp_is_regular_file(marker) == 1;
    free(marker);
    return !entries || ours;
}

/* The passes directory under its name; an older one is replaced only when it is a passes directory. */
static int commit_passes(sp_partial *pd)
{
    char *final = strdup(pd->final_path ? pd->final_path : "");
    char *old = final ? sp_path_join_alloc(final, "passes.json") : NULL;
    int ret = sp_partial_dir_commit(pd, old && sp_is_regular_file(old) == 1 ? SP_PARTIAL_REPLACE : 0);
    if (ret == -EEXIST)
        fprintf(stderr, "sunprobe relight: --passes %s exists and is not a passes directory (no passes.json): not "
                        "replaced\n", final);
    else if (ret)
        sp_cmd_failf("relight", ret, "--passes %s", final);
    free(old);
    free(final);
    return sp_exit_for_error(ret);
}

/* The view and light of c->a (and --save-camera written); 0 or an exit code (message printed). */
static int make_view(relight_ctx *c, sp_face_view *v)
{
    const relight_args *a = c->a;
    int ret = set_view(c, v);
    if (!ret && a->camera_in)
        ret = read_camera(a, v);
    if (!ret && a->camera_out)
        ret = save_camera(a, v);
    if (ret)
        return ret;
    set_light(c, v);
    v->supersample = a->supersample ? a->supersample : v->supersample;
    if (c->bg_is_capture || a->passes_dir)
        v->vertex_mask = face_mask_for(c);
    if (a->sky_turn != 0.0) { /* the panel's new light: the sky about the vertical */
        double t = a->sky_turn * M_PI / 180.0;
        double R[9] = { cos(t), -sin(t), 0, sin(t), cos(t), 0, 0, 0, 1 };
        memcpy(v->env_to_world, R, sizeof(R));
    }
    return 0;
}

int relight_tile(relight_ctx *c, uint8_t **rgba, int *W, int *H)
{
    sp_face_view v;
    int ret = make_view(c, &v);
    if (ret)
        return ret;
    light_sums ls = { 0 };
    size_t n = (size_t)v.width * (size_t)v.height;
    ret = render_sums(c, &v, &ls);
    *rgba = ret ? NULL : malloc(n * 4);
    if (*rgba)
        relight_encode(c, ls.sum[PASS_BEAUTY], ls.cover, n, v.exposure, *rgba);
    free_sums(&ls);
    *W = v.width;
    *H = v.height;
    return *rgba ? 0 : sp_cmd_fail("relight", ret ? ret : -ENOMEM, "--panel");
}

/* --albedo-paint-image: keyframe N's view at its frame's size, its depth, the paint projected; an exit code. */
static int paint_from_image(relight_ctx *c)
{
    relight_args *keep = c->a, k = *keep;
    k.keyframe = k.paint_keyframe, k.have_view = 1, k.have_orbit = 0, k.fov_deg = 0.0, k.width = k.height = 0;
    k.scale = 0, k.camera_in = k.camera_out = NULL, k.supersample = 1, k.sky_turn = 0.0;
    c->a = &k;
    sp_face_view v;
    int ret = set_view(c, &v);
    float *depth = ret ? NULL : malloc(sizeof(float) * (size_t)v.width * (size_t)v.height);
    v.supersample = 1;
    sp_face_passes p = { .depth = depth };
    if (!ret && (!depth || (ret = sp_face_asset_render_passes(&c->fa, &v, &p))))
        ret = sp_cmd_fail("relight", depth ? ret : -ENOMEM, "--albedo-paint-image");
    if (!ret)
        ret = relight_paint_image(c, &v, depth, k.paint_image);
    free(depth);
    c->a = keep;
    return ret;
}

static int run_relight(relight_ctx *c, sp_partial *pd)
{
    const relight_args *a = c->a;
    if (relight_ends_with(a->out, ".exr") && !HAVE_OPENIMAGEIO) {
        fprintf(stderr, "sunprobe relight: -o %s: OpenEXR needs OpenImageIO (-Dopenimageio=enabled); .pfm is linear "
                        "too\n", a->out);
        return SP_EXIT_DISABLED;
    }
    if (a->passes_dir && !passes_dir_usable(a->passes_dir)) {
        fprintf(stderr, "sunprobe relight: --passes %s exists and is not an empty or passes directory (no "
                        "passes.json): not replaced\n", a->passes_dir);
        return SP_EXIT_USAGE;
    }
    int ret = a->passes_dir ? sp_partial_dir_open(pd, a->passes_dir) : 0;
    if (ret)
        return sp_cmd_failf("relight", ret, "--passes %s", a->passes_dir);
    if ((ret = read_inputs(c)))
        return ret;
    if (a->paint_image && (ret = paint_from_image(c)))
        return ret;
    if (a->panel)
        return relight_panel(c);
    sp_face_view v;
    if ((ret = make_view(c, &v)))
        return ret;
    if ((ret = render_and_write(c, &v, pd)))
        return sp_cmd_fail("relight", ret, a->out);
    if (a->passes_dir && (ret = commit_passes(pd)))
        return ret;
    printf("relight: wrote %s (%dx%d)%s%s\n", a->out, v.width, v.height, a->passes_dir ? " and passes in " : "",
           a->passes_dir ? a->passes_dir : "");
    return SP_EXIT_OK;
}

int sp_cmd_relight(int argc, char **argv)
{
    relight_args a = { .background_keyframe = -1 };
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++)
        a.spec_scale[k] = 1.0;
    int p = parse_relight(argc, argv, &a);
    if (p)
        return p > 0 ? SP_EXIT_OK : SP_EXIT_USAGE;
    relight_ctx c = { .a = &a };
    sp_partial pd = { 0 };
    sp_cmd_signals sig; /* a stop signal is acted on before OUT is written; once it is, the run ends with 0 */
    sp_cmd_catch_signals(&sig);
    int ret = run_relight(&c, &pd);
    sp_partial_dir_abort(&pd); /* nothing once committed; before the restore, so no signal leaves it half removed */
    sp_cmd_restore_signals(&sig);
    sp_face_asset_free(&c.fa);
    sp_json_free(c.cams);
    sp_json_free(c.manifest);
    free(c.bg);
    free(c.bg_raw);
    free(c.fit_mask);
    if (c.have_model)
        sp_face_model_free(&c.model);
    return ret;
}
