"""GLSL sources of the viewer's GPU pipeline: refocus passes, Sobel, compression, the frame.

The vertex shader and the phosphene profile are the presenter's
(:mod:`experiment.presentation.drawing`).

Each shader computes what :mod:`experiment.viewer.reference` computes with numpy; the tests
compare the two pixel by pixel.
"""

from __future__ import annotations

from experiment.presentation.drawing import PHOSPHENE_GLSL

__all__ = [
    "PASS1_SHADER",
    "PASS2_SHADER",
    "SOBEL_SHADER",
    "COMPRESS_SHADER",
    "DRAW_SHADER",
]

PASS1_SHADER = """
#version 330
uniform sampler2DArray u_views;  // RGBA32F: layer (group, v), channel k = grid row 4 group + k
uniform int u_rows;
uniform int u_cols;
uniform int u_nv;
uniform ivec2 u_m[32];
uniform vec2 u_w[32];
out vec4 f_out;
void main() {
    ivec2 q = ivec2(gl_FragCoord.xy);
    int grp = q.y / u_rows;
    int y = q.y - grp * u_rows;
    vec4 acc = vec4(0.0);
    for (int v = 0; v < u_nv; v++) {
        int layer = grp * u_nv + v;
        int xs = q.x - u_m[v].x;
        if (xs >= 0 && xs < u_cols)
            acc += u_w[v].x * texelFetch(u_views, ivec3(xs, y, layer), 0);
        if (u_w[v].y != 0.0) {
            xs = q.x - u_m[v].y;
            if (xs >= 0 && xs < u_cols)
                acc += u_w[v].y * texelFetch(u_views, ivec3(xs, y, layer), 0);
        }
    }
    f_out = acc;
}
"""

PASS2_SHADER = """
#version 330
uniform sampler2D u_partial;     // RGBA32F, band = group of 4 grid rows
uniform sampler2D u_inv;
uniform int u_rows;
uniform int u_nu;
uniform ivec2 u_m[32];
uniform vec2 u_w[32];
out float f_out;
void main() {
    ivec2 q = ivec2(gl_FragCoord.xy);
    float acc = 0.0;
    for (int u = 0; u < u_nu; u++) {
        int grp = u / 4;
        int k = u - 4 * grp;
        int ys = q.y - u_m[u].x;
        if (ys >= 0 && ys < u_rows)
            acc += u_w[u].x * texelFetch(u_partial, ivec2(q.x, grp * u_rows + ys), 0)[k];
        if (u_w[u].y != 0.0) {
            ys = q.y - u_m[u].y;
            if (ys >= 0 && ys < u_rows)
                acc += u_w[u].y * texelFetch(u_partial, ivec2(q.x, grp * u_rows + ys), 0)[k];
        }
    }
    f_out = clamp(acc * texelFetch(u_inv, q, 0).r, 0.0, 1.0);
}
"""

SOBEL_SHADER = """
#version 330
uniform sampler2D u_src;
uniform ivec4 u_crop;   // x0, y0, w, h
out float f_out;
int refl(int i, int n) { return i < 0 ? -i - 1 : (i >= n ? 2 * n - i - 1 : i); }
float px(int x, int y) {
    ivec2 at = ivec2(u_crop.x + refl(x, u_crop.z), u_crop.y + refl(y, u_crop.w));
    return texelFetch(u_src, at, 0).r;
}
void main() {
    ivec2 q = ivec2(gl_FragCoord.xy);
    int x = q.x, y = q.y;
    float a = px(x - 1, y - 1), b = px(x, y - 1), c = px(x + 1, y - 1);
    float d = px(x - 1, y), f = px(x + 1, y);
    float g = px(x - 1, y + 1), h = px(x, y + 1), i = px(x + 1, y + 1);
    float gy = 0.25 * (g + 2.0 * h + i) - 0.25 * (a + 2.0 * b + c);
    float gx = 0.25 * (c + 2.0 * f + i) - 0.25 * (a + 2.0 * d + g);
    f_out = sqrt(gx * gx + gy * gy) / sqrt(2.0);
}
"""

COMPRESS_SHADER = """
#version 330
uniform sampler2D u_mag;
uniform sampler2D u_src;
uniform ivec4 u_crop;
uniform isampler2D u_rb;
uniform isampler2D u_cb;
uniform sampler2D u_kmin;
uniform float u_t;
uniform int u_levels;
out float f_out;
void main() {
    ivec2 q = ivec2(gl_FragCoord.xy);
    int r0 = texelFetch(u_rb, ivec2(q.y, 0), 0).r, r1 = texelFetch(u_rb, ivec2(q.y + 1, 0), 0).r;
    int c0 = texelFetch(u_cb, ivec2(q.x, 0), 0).r, c1 = texelFetch(u_cb, ivec2(q.x + 1, 0), 0).r;
    if (u_levels <= 2) {
        int n = 0;
        for (int r = r0; r < r1; r++)
            for (int c = c0; c < c1; c++)
                if (texelFetch(u_mag, ivec2(c, r), 0).r > u_t) n++;
        f_out = float(n) >= texelFetch(u_kmin, q, 0).r ? 1.0 : 0.0;
    } else {
        float s = 0.0;
        for (int r = r0; r < r1; r++)
            for (int c = c0; c < c1; c++)
                s += texelFetch(u_src, ivec2(u_crop.x + c, u_crop.y + r), 0).r;
        float mean = s / float((r1 - r0) * (c1 - c0));
        float k = min(floor(mean * float(u_levels)), float(u_levels - 1));
        f_out = k / float(u_levels - 1);
    }
}
"""

DRAW_SHADER = (
    """
#version 330
uniform int u_kind;          // 0 grey, 1 edges (mag > t), 2 phosphenes, 3 text
uniform int u_screen_rows;
uniform ivec4 u_rect;        // left, top, cols, rows (screen, top-left origin)
uniform ivec4 u_src_rect;    // x0, y0, w, h inside u_tex (grey/edges); grid for phosphenes
uniform sampler2D u_tex;
uniform sampler2D u_alive;
uniform usampler2D u_text;
uniform float u_t;
uniform ivec4 u_box;         // zoom box in source cells (x, y, w, h); w = 0: none
uniform vec3 u_box_rgb;
uniform ivec3 u_marker;      // marker x, y in source cells and its arm; arm < 0: none
uniform vec3 u_marker_rgb;
uniform int u_phos;          // 1 gaussian, 2 disc
uniform float u_phos_size;
uniform vec2 u_rot;          // cos, sin of the array's rotation (counter-clockwise on screen)
out vec4 f_color;

float cell_value(ivec2 c) {
    return texelFetch(u_tex, c, 0).r * texelFetch(u_alive, c, 0).r;
}
"""
    + PHOSPHENE_GLSL
    + """
float phosphene(ivec2 p, ivec2 grid) {
    vec2 pitch = vec2(u_rect.zw) / vec2(grid);
    vec2 pos = vec2(p) + 0.5;
    if (u_rot.y != 0.0 || u_rot.x != 1.0) {
        // the point of the upright array that this pixel shows (image rows run downwards)
        vec2 c = vec2(u_rect.zw) * 0.5;
        vec2 d = pos - c;
        pos = c + vec2(d.x * u_rot.x - d.y * u_rot.y, d.x * u_rot.y + d.y * u_rot.x);
    }
    return phosphene_sum(pos, pitch, grid);
}

void main() {
    ivec2 q = ivec2(gl_FragCoord.xy);
    ivec2 pix = ivec2(q.x, u_screen_rows - 1 - q.y);
    ivec2 p = pix - u_rect.xy;
    if (u_kind == 3) {
        f_color = vec4(vec3(float(texelFetch(u_text, p, 0).r) / 255.0), 1.0);
        return;
    }
    if (u_kind == 2) {
        f_color = vec4(vec3(phosphene(p, u_src_rect.zw)), 1.0);
        return;
    }
    ivec2 cell = ((2 * p + 1) * u_src_rect.zw) / (2 * u_rect.zw);
    if (u_marker.z >= 0) {
        bool on_x = cell.x == u_marker.x && abs(cell.y - u_marker.y) <= u_marker.z;
        bool on_y = cell.y == u_marker.y && abs(cell.x - u_marker.x) <= u_marker.z;
        if (on_x || on_y) {
            f_color = vec4(u_marker_rgb, 1.0);
            return;
        }
    }
    if (u_box.z > 0) {
        bool in_c = cell.x >= u_box.x && cell.x <= u_box.x + u_box.z - 1;
        bool in_r = cell.y >= u_box.y && cell.y <= u_box.y + u_box.w - 1;
        bool on_c = cell.x == u_box.x || cell.x == u_box.x + u_box.z - 1;
        bool on_r = cell.y == u_box.y || cell.y == u_box.y + u_box.w - 1;
        if ((on_r && in_c) || (on_c && in_r)) {
            f_color = vec4(u_box_rgb, 1.0);
            return;
        }
    }
    float v = texelFetch(u_tex, u_src_rect.xy + cell, 0).r;
    if (u_kind == 1) v = v > u_t ? 1.0 : 0.0;
    f_color = vec4(vec3(clamp(v, 0.0, 1.0)), 1.0);
}
"""
)
