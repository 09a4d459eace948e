// Built as a module loaded on the first text() (csg/text.cpp): fontconfig, FreeType and HarfBuzz
// bring about ten shared libraries that every other command would load at start-up.
// The same libraries OpenSCAD uses for text(), called the way its FreetypeRenderer and FontCache
// call them (read in its source, tag openscad-2021.01), so that the outlines are its outlines.
#include "csg/text_module.h"

#include <cmath>
#include <mutex>
#include <stdexcept>

#include <fontconfig/fontconfig.h>
#include <ft2build.h>
#include FT_FREETYPE_H
#include FT_GLYPH_H
#include FT_OUTLINE_H
#include <hb-ft.h>
#include <hb.h>

namespace isoforge::csg {

namespace {

constexpr double kScale = 1e5;            // FreetypeRenderer::scale: outline units per model unit
constexpr double kUnscale = 1 / 1.024e5;  // FreetypeRenderer::unscale: for HarfBuzz positions and boxes

/// DrawingCallback: outlines of one glyph, points at size * (v + offset + advance).
struct Drawing {
    double size;
    int segments;
    glm::dvec2 offset{0.0}, advance{0.0}, pen{0.0};
    Profile glyph;
    Outline2 outline;

    void add(const glm::dvec2& v) { outline.points.push_back(size * (v + offset + advance)); }
    void close() {
        if (!outline.points.empty()) glyph.outlines.push_back(std::move(outline));
        outline = Outline2{};
    }
    static glm::dvec2 at(const FT_Vector* v) { return glm::dvec2(double(v->x) / kScale, double(v->y) / kScale); }
    static Drawing& of(void* user) { return *static_cast<Drawing*>(user); }
    static int moveTo(const FT_Vector* to, void* user) {
        Drawing& d = of(user);
        d.close();
        d.pen = at(to);
        d.add(d.pen);
        return 0;
    }
    static int lineTo(const FT_Vector* to, void* user) {
        Drawing& d = of(user);
        d.pen = at(to);
        d.add(d.pen);
        return 0;
    }
    static int conicTo(const FT_Vector* c1, const FT_Vector* to, void* user) {
        Drawing& d = of(user);
        const glm::dvec2 c = at(c1), e = at(to);
        for (int i = 1; i <= d.segments; ++i) {
            const double a = i * (1.0 / double(d.segments));
            d.add(d.pen * std::pow(1 - a, 2) + c * 2.0 * std::pow(1 - a, 1) * a + e * std::pow(a, 2));
        }
        d.pen = e;
        return 0;
    }
    static int cubicTo(const FT_Vector* c1, const FT_Vector* c2, const FT_Vector* to, void* user) {
        Drawing& d = of(user);
        const glm::dvec2 p1 = at(c1), p2 = at(c2), e = at(to);
        for (int i = 1; i <= d.segments; ++i) {
            const double a = i * (1.0 / double(d.segments));
            d.add(d.pen * std::pow(1 - a, 3) + p1 * 3.0 * std::pow(1 - a, 2) * a +
                  p2 * 3.0 * std::pow(1 - a, 1) * std::pow(a, 2) + e * std::pow(a, 3));
        }
        d.pen = e;
        return 0;
    }
};

/// FontCache::find_face_fontconfig: the best match for a fontconfig name ("Liberation Sans:style=Regular"
/// when none is given), outline and scalable, with a Unicode character map.
FT_Face findFace(FT_Library lib, const std::string& name, std::string* used) {
    static std::mutex m;  // one configuration, loaded once (it scans the fonts) and kept, as OpenSCAD's FontCache
    std::lock_guard<std::mutex> lock(m);
    static FcConfig* config = FcInitLoadConfigAndFonts();
    if (!config) return nullptr;
    FcPattern* pattern = FcNameParse(reinterpret_cast<const FcChar8*>(name.c_str()));
    FcPatternAddBool(pattern, FC_OUTLINE, FcTrue);
    FcPatternAddBool(pattern, FC_SCALABLE, FcTrue);
    FcConfigSubstitute(config, pattern, FcMatchPattern);
    FcDefaultSubstitute(pattern);
    FcResult result;
    FcPattern* match = FcFontMatch(config, pattern, &result);
    FT_Face face = nullptr;
    FcChar8* file = nullptr;
    int index = 0;
    if (match && FcPatternGetString(match, FC_FILE, 0, &file) == FcResultMatch) {
        FcPatternGetInteger(match, FC_INDEX, 0, &index);
        if (FT_New_Face(lib, reinterpret_cast<const char*>(file), index, &face) != 0) face = nullptr;
        if (face && used) *used = reinterpret_cast<const char*>(file);
    }
    if (match) FcPatternDestroy(match);
    FcPatternDestroy(pattern);
    if (face) FT_Select_Charmap(face, FT_ENCODING_UNICODE);
    return face;
}

std::vector<Profile> glyphOutlines(const TextParams& p, std::string* fontUsed) {
    FT_Library lib = nullptr;
    if (FT_Init_FreeType(&lib) != 0) throw std::runtime_error("text(): FreeType could not start");
    struct Done {
        FT_Library lib;
        FT_Face face = nullptr;
        hb_font_t* font = nullptr;
        hb_buffer_t* buf = nullptr;
        ~Done() {
            if (buf) hb_buffer_destroy(buf);
            if (font) hb_font_destroy(font);
            if (face) FT_Done_Face(face);
            FT_Done_FreeType(lib);
        }
    } done{lib};
    std::string trimmed = p.font;
    trimmed.erase(0, trimmed.find_first_not_of(" \t"));
    trimmed.erase(trimmed.find_last_not_of(" \t") + 1);
    done.face = findFace(lib, trimmed.empty() ? "Liberation Sans:style=Regular" : trimmed, fontUsed);
    if (!done.face) throw std::runtime_error("text(): no font found for '" + p.font + "' (fontconfig)");
    if (FT_Set_Char_Size(done.face, 0, FT_F26Dot6(kScale), 100, 100) != 0)
        throw std::runtime_error("text(): cannot size the font");
    done.font = hb_ft_font_create(done.face, nullptr);
    done.buf = hb_buffer_create();
    hb_buffer_set_direction(done.buf, hb_direction_from_string(p.direction.c_str(), -1));
    hb_buffer_set_script(done.buf, hb_script_from_string(p.script.c_str(), -1));
    hb_buffer_set_language(done.buf, hb_language_from_string(p.language.c_str(), -1));
    hb_buffer_add_utf8(done.buf, p.text.c_str(), int(p.text.size()), 0, int(p.text.size()));
    hb_buffer_guess_segment_properties(done.buf);  // what is not given (our own scenes): from the text
    hb_shape(done.font, done.buf, nullptr, 0);
    unsigned count = 0;
    hb_glyph_info_t* info = hb_buffer_get_glyph_infos(done.buf, &count);
    hb_glyph_position_t* pos = hb_buffer_get_glyph_positions(done.buf, &count);

    struct Glyph {
        FT_Glyph glyph;
        const hb_glyph_position_t* pos;
    };
    std::vector<Glyph> glyphs;
    for (unsigned i = 0; i < count; ++i) {
        if (FT_Load_Glyph(done.face, info[i].codepoint, FT_LOAD_DEFAULT) != 0) continue;
        FT_Glyph g;
        if (FT_Get_Glyph(done.face->glyph, &g) != 0) continue;
        glyphs.push_back({g, &pos[i]});
    }
    const bool horizontal = HB_DIRECTION_IS_HORIZONTAL(hb_buffer_get_direction(done.buf));
    double width = 0, ascend = 0, descend = 0;
    for (const Glyph& g : glyphs) {
        FT_BBox box;
        FT_Glyph_Get_CBox(g.glyph, FT_GLYPH_BBOX_GRIDFIT, &box);
        if (horizontal) {
            width += g.pos->x_advance * kUnscale * p.spacing;
            ascend = std::max(ascend, std::max(0.0, box.yMax * kUnscale));
            descend = std::max(descend, std::max(0.0, -box.yMin * kUnscale));
        } else {
            width = std::max(width, (box.xMax - box.xMin) * kUnscale);
            ascend += g.pos->y_advance * kUnscale * p.spacing;
        }
    }
    const double x0 = p.halign == "right" ? -width : p.halign == "center" ? -width / 2 : 0.0;
    const double y0 = p.valign == "top"      ? -ascend
                      : p.valign == "center" ? descend / 2 - ascend / 2
                      : p.valign == "bottom" ? descend
                                             : 0.0;
    FT_Outline_Funcs funcs{};
    funcs.move_to = &Drawing::moveTo;
    funcs.line_to = &Drawing::lineTo;
    funcs.conic_to = &Drawing::conicTo;
    funcs.cubic_to = &Drawing::cubicTo;
    Drawing d{p.size, std::max(p.segments, 1), {}, {}, {}, {}, {}};
    std::vector<Profile> perGlyph;
    for (const Glyph& g : glyphs) {
        d.glyph = Profile{};
        d.outline = Outline2{};
        d.offset = glm::dvec2(x0 + g.pos->x_offset * kUnscale, y0 + g.pos->y_offset * kUnscale);
        FT_Outline outline = reinterpret_cast<FT_OutlineGlyph>(g.glyph)->outline;
        FT_Outline_Decompose(&outline, &funcs, &d);
        d.advance += glm::dvec2(g.pos->x_advance * kUnscale * p.spacing, g.pos->y_advance * kUnscale * p.spacing);
        d.close();
        if (!d.glyph.outlines.empty()) perGlyph.push_back(std::move(d.glyph));
        FT_Done_Glyph(g.glyph);
    }
    return perGlyph;
}

const TextModule kModule{kTextModuleAbi, &glyphOutlines};

}  // namespace
}  // namespace isoforge::csg

extern "C" __attribute__((visibility("default"))) const isoforge::csg::TextModule* isoforge_text_module() {
    return &isoforge::csg::kModule;
}
