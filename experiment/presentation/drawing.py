"""What the presenter draws: the GLSL program and the text image (no GL calls here).

The border frame and the background are plain clears; one fragment shader
(:data:`FRAGMENT_SHADER`), scissored to the image (or text) rectangle, draws every pixel inside
it:

- *stimulus*: the stimulus's rectangle (:func:`experiment.presentation.frame.stimulus_rect_px`);
  everything around it has the border colour (Jung et al. 2015, Sec. 3.1: a blue border). Each
  screen pixel takes the value of exactly one stimulus cell
  (:func:`experiment.presentation.frame.cell_index`). No texture filtering is involved.
- *blank* (between trials): the image area in the stimulus's "0" colour, the border around it,
  an optional fixation cross in the centre.
- *text* (instructions, pause, end): white text on black, rendered with Pillow into a texture
  (:func:`text_image`).
- optional *phosphene view* (beyond the paper): every cell drawn as a Gaussian or disc phosphene.

Gamma correction (protocol's ``gamma``) is applied in the shader to stimulus luminance only:
stimulus values are fractions of maximum luminance, sent to the screen as ``v ** (1 / gamma)``.
Colours (border, text, fixation) are device RGB values as written in the protocol (``0, 0, 255``
is the paper's blue whatever the gamma). For binary stimuli gamma changes nothing (0 and 1 are
fixed points).
"""

from __future__ import annotations

import math
from typing import Any

__all__ = [
    "FIXATION_HALF_DEG",
    "FIXATION_THICKNESS_PX",
    "VERTEX_SHADER",
    "FRAGMENT_SHADER",
    "PHOSPHENE_GLSL",
    "MODE_STIMULUS",
    "MODE_BLANK",
    "MODE_TEXT",
    "text_image",
]

#: Fixation cross arm length (half-width), degrees; ours, not the paper's (a small cross).
FIXATION_HALF_DEG: float = 0.25
#: Fixation cross line thickness, px; ours.
FIXATION_THICKNESS_PX: int = 3

#: Values of the shader's ``u_mode``: what the fragment shader draws.
MODE_STIMULUS, MODE_BLANK, MODE_TEXT = 0, 1, 2

#: One triangle that covers the whole viewport (no vertex buffer: ``gl_VertexID`` only).
VERTEX_SHADER = """
#version 330
void main() {
    vec2 p = vec2((gl_VertexID == 1) ? 3.0 : -1.0, (gl_VertexID == 2) ? 3.0 : -1.0);
    gl_Position = vec4(p, 0.0, 1.0);
}
"""

#: GLSL function ``phosphene_sum(pos, pitch, grid)``: at ``pos`` (pixels inside the image
#: rectangle, top-left origin) the sum of the 3x3 nearest phosphenes' profiles, capped at 1, on a
#: ``grid`` (cols, rows) of cells ``pitch`` pixels apart. The shader that includes it declares
#: ``u_phos`` (1 gaussian, 2 disc) and ``u_phos_size`` (disc diameter or Gaussian FWHM as a
#: fraction of the pitch) and defines ``float cell_value(ivec2 cell)`` before it. The presenter
#: and the viewer both draw phosphenes with it; its numpy twin is
#: :func:`stimuli.implants.render_phosphenes`.
PHOSPHENE_GLSL = """
float phosphene_sum(vec2 pos, vec2 pitch, ivec2 grid) {
    ivec2 c0 = ivec2(floor(pos / pitch));
    float d_size = u_phos_size * min(pitch.x, pitch.y);
    float sigma = d_size / 2.3548;
    float total = 0.0;
    for (int dy = -1; dy <= 1; dy++) {
        for (int dx = -1; dx <= 1; dx++) {
            ivec2 c = c0 + ivec2(dx, dy);
            if (c.x < 0 || c.y < 0 || c.x >= grid.x || c.y >= grid.y) continue;
            float v = cell_value(c);
            if (v == 0.0) continue;  // adds exactly 0: skipping it only saves an exp
            vec2 d = pos - (vec2(c) + 0.5) * pitch;
            float r2 = d.y * d.y + d.x * d.x;
            if (u_phos == 1) total += v * exp(-r2 / (2.0 * sigma * sigma));
            else if (r2 <= 0.25 * d_size * d_size) total += v;
        }
    }
    return min(total, 1.0);
}
"""

#: Draws every pixel of the stimulus, blank or text screen (``u_mode``). Integer pixel coordinates
#: with the origin at the top-left, so that rows match numpy's.
FRAGMENT_SHADER = (
    """
#version 330
uniform int u_mode;          // 0 stimulus, 1 blank (+fixation), 2 text
uniform ivec2 u_screen;      // (cols, rows)
uniform ivec4 u_rect;        // (left, top, cols, rows)
uniform ivec2 u_grid;        // stimulus (cols, rows)
uniform vec3 u_border;
uniform int u_border_px;     // frame width, -1 = the whole surround
uniform vec3 u_background;
uniform vec3 u_fg;
uniform vec3 u_bg;
uniform float u_inv_gamma;
uniform int u_fixation;      // half-length of the cross arms in px, 0 = none
uniform int u_fix_thick;
uniform vec3 u_fix_rgb;
uniform int u_phos;          // 0 off, 1 gaussian, 2 disc
uniform float u_phos_size;   // diameter (disc) or FWHM (gaussian) as a fraction of the pitch
uniform ivec4 u_text_rect;   // (left, top, cols, rows)
uniform sampler2D u_stim;    // R32F (RGB32F for colour), row 0 = top row of the stimulus
uniform int u_colour;        // 1: u_stim is a colour photo, drawn as it is
uniform sampler2D u_text;    // R8 coverage, row 0 = top
out vec4 f_color;

vec3 lum_to_rgb(float v) {
    return mix(u_bg, u_fg, pow(clamp(v, 0.0, 1.0), u_inv_gamma));
}

float cell_value(ivec2 c) {
    return texelFetch(u_stim, c, 0).r;
}
"""
    + PHOSPHENE_GLSL
    + """

void main() {
    ivec2 q = ivec2(gl_FragCoord.xy);
    ivec2 pix = ivec2(q.x, u_screen.y - 1 - q.y);   // (col, row) from the top-left
    if (u_mode == 2) {
        vec3 c = vec3(0.0);
        ivec2 t = pix - u_text_rect.xy;
        if (t.x >= 0 && t.y >= 0 && t.x < u_text_rect.z && t.y < u_text_rect.w) {
            c = vec3(texelFetch(u_text, t, 0).r);
        }
        f_color = vec4(c, 1.0);
        return;
    }
    ivec2 p = pix - u_rect.xy;
    if (p.x < 0 || p.y < 0 || p.x >= u_rect.z || p.y >= u_rect.w) {
        ivec2 out_by = max(max(-p, p - u_rect.zw + 1), ivec2(0));
        bool in_frame = u_border_px < 0 || max(out_by.x, out_by.y) <= u_border_px;
        f_color = vec4(in_frame ? u_border : u_background, 1.0);
        return;
    }
    if (u_mode == 1) {
        vec3 c = u_bg;
        ivec2 d = abs(pix - u_screen / 2);
        int h = u_fix_thick / 2;
        if (u_fixation > 0 && ((d.x <= u_fixation && d.y <= h) || (d.y <= u_fixation && d.x <= h)))
            c = u_fix_rgb;
        f_color = vec4(c, 1.0);
        return;
    }
    if (u_colour == 1) {
        ivec2 cell = ((2 * p + 1) * u_grid) / (2 * u_rect.zw);
        vec3 c = clamp(texelFetch(u_stim, cell, 0).rgb, 0.0, 1.0);
        f_color = vec4(pow(c, vec3(u_inv_gamma)), 1.0);
        return;
    }
    float v;
    if (u_phos > 0) {
        v = phosphene_sum(vec2(p) + 0.5, vec2(u_rect.zw) / vec2(u_grid), u_grid);
    } else {
        ivec2 cell = ((2 * p + 1) * u_grid) / (2 * u_rect.zw);
        v = texelFetch(u_stim, cell, 0).r;
    }
    f_color = vec4(lum_to_rgb(v), 1.0);
}
"""
)


def text_image(text: str, screen_shape_px: tuple[int, int], font_px: int) -> Any:
    """Render ``text`` white on black, lines centred, cropped to its box plus a 1 px margin.

    Parameters
    ----------
    text : str
        One or more lines.
    screen_shape_px : (rows, cols)
        The screen; the image is never larger.
    font_px : int
        Font size, px (Pillow's default font).

    Returns
    -------
    PIL.Image.Image
        Mode ``'L'`` (0 black, 255 white), at most the screen's size.
    """
    from PIL import Image, ImageDraw, ImageFont

    rows, cols = screen_shape_px
    font = ImageFont.load_default(size=font_px)
    probe = ImageDraw.Draw(Image.new("L", (1, 1)))
    box = [
        int(math.floor(v))
        for v in probe.multiline_textbbox((0, 0), text, font=font, align="center")
    ]
    box[2:] = [v + 1 for v in box[2:]]
    w = max(1, min(cols, box[2] - box[0] + 2))
    h = max(1, min(rows, box[3] - box[1] + 2))
    im = Image.new("L", (w, h), 0)
    ImageDraw.Draw(im).multiline_text(
        (-box[0] + 1, -box[1] + 1), text, fill=255, font=font, align="center"
    )
    return im
