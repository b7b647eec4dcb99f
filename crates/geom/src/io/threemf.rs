//! 3MF (core specification 1.x): an OPC package, that is a ZIP holding
//! `[Content_Types].xml`, `_rels/.rels` and the model part (`3D/3dmodel.model`).
//!
//! Reading follows the package relationship to the model part, merges every build
//! item whose object is of type `model` or `solidsupport` (meshes and, recursively,
//! components, with their transforms; components in other parts through the
//! production extension's `p:path`), and converts the model's unit to millimetres.
//! Materials, colours, metadata and other extensions are ignored. The XML is read
//! by a small scanner of our own: the model part is flat (no mixed content), so a
//! full XML parser buys nothing.
//!
//! Writing gives one `<object type="model">` holding the whole mesh, in millimetres,
//! with the shortest decimal of every f64 (a round trip is exact), in a deflated ZIP
//! whose entries carry a fixed timestamp (1980-01-01) and permissions: the same mesh
//! always gives the same bytes. Triangles that repeat a vertex index are left out,
//! as the specification forbids them (they have no area and no volume).

use std::collections::HashMap;
use std::io::{Cursor, Read, Write};
use std::path::Path;

use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, DateTime, ZipArchive, ZipWriter};

use super::{checked_mesh, parse_error};
use crate::error::Result;
use crate::math::Point3;
use crate::mesh::Mesh;

/// The model part that writers use and readers fall back to.
const MODEL_PART: &str = "3D/3dmodel.model";
/// The relationship type of the package's 3-D model part.
const REL_3DMODEL: &str = "http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel";
/// The core namespace.
const NS_CORE: &str = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02";
/// An uncompressed part larger than this is refused (a ZIP bomb, not a model).
const MAX_PART_BYTES: u64 = 1 << 31;
/// How deep components may nest (and production parts refer to each other).
const MAX_DEPTH: usize = 64;
/// Object instances (build items and components, expanded) a build may place.
const MAX_INSTANCES: u64 = 1 << 24;

/// Memoised expansion counts per (part, object id).
type Counts = HashMap<(String, u64), (u64, u64)>;

const CONTENT_TYPES: &str = concat!(
    "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n",
    "<Types xmlns=\"http://schemas.openxmlformats.org/package/2006/content-types\">\n",
    " <Default Extension=\"rels\" ContentType=\"application/vnd.openxmlformats-package.relationships+xml\"/>\n",
    " <Default Extension=\"model\" ContentType=\"application/vnd.ms-package.3dmanufacturing-3dmodel+xml\"/>\n",
    "</Types>\n"
);

const RELS: &str = concat!(
    "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n",
    "<Relationships xmlns=\"http://schemas.openxmlformats.org/package/2006/relationships\">\n",
    " <Relationship Target=\"/3D/3dmodel.model\" Id=\"rel0\" ",
    "Type=\"http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel\"/>\n",
    "</Relationships>\n"
);

/// Writes a 3MF package holding `mesh` as one object, in millimetres; deterministic
/// (see the module docs).
pub fn write_3mf(w: &mut impl Write, mesh: &Mesh) -> std::io::Result<()> {
    let options = SimpleFileOptions::DEFAULT
        .compression_method(CompressionMethod::Deflated)
        // Level 1: a 51 MB model (588k triangles) deflates to 8.2 MB in 0.33 s here;
        // level 6 gives 5.2 MB but takes 3.3 s, longer than the reconstruction.
        .compression_level(Some(1))
        .last_modified_time(DateTime::DEFAULT)
        .unix_permissions(0o644);
    let mut zip = ZipWriter::new(Cursor::new(Vec::new()));
    zip.start_file("[Content_Types].xml", options).map_err(std::io::Error::other)?;
    zip.write_all(CONTENT_TYPES.as_bytes())?;
    zip.start_file("_rels/.rels", options).map_err(std::io::Error::other)?;
    zip.write_all(RELS.as_bytes())?;
    zip.start_file(MODEL_PART, options).map_err(std::io::Error::other)?;
    {
        let mut m = std::io::BufWriter::with_capacity(1 << 16, &mut zip);
        write_model(&mut m, mesh)?;
        m.flush()?;
    }
    let bytes = zip.finish().map_err(std::io::Error::other)?.into_inner();
    w.write_all(&bytes)
}

fn write_model(w: &mut impl Write, mesh: &Mesh) -> std::io::Result<()> {
    writeln!(w, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>")?;
    writeln!(w, "<model unit=\"millimeter\" xml:lang=\"en-US\" xmlns=\"{NS_CORE}\">")?;
    writeln!(w, " <metadata name=\"Application\">s2g-geom</metadata>")?;
    writeln!(w, " <resources>")?;
    writeln!(w, "  <object id=\"1\" type=\"model\">")?;
    writeln!(w, "   <mesh>")?;
    writeln!(w, "    <vertices>")?;
    for p in mesh.vertices() {
        writeln!(w, "     <vertex x=\"{:?}\" y=\"{:?}\" z=\"{:?}\"/>", p.x, p.y, p.z)?;
    }
    writeln!(w, "    </vertices>")?;
    writeln!(w, "    <triangles>")?;
    for t in mesh.triangles() {
        if t[0] != t[1] && t[1] != t[2] && t[2] != t[0] {
            writeln!(w, "     <triangle v1=\"{}\" v2=\"{}\" v3=\"{}\"/>", t[0], t[1], t[2])?;
        }
    }
    writeln!(w, "    </triangles>")?;
    writeln!(w, "   </mesh>")?;
    writeln!(w, "  </object>")?;
    writeln!(w, " </resources>")?;
    writeln!(w, " <build>")?;
    writeln!(w, "  <item objectid=\"1\"/>")?;
    writeln!(w, " </build>")?;
    writeln!(w, "</model>")
}

/// Parses a 3MF package: every build item of type `model` or `solidsupport`, merged
/// into one mesh in millimetres (see the module docs).
pub fn read_3mf(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let mut package = Package::open(bytes, path)?;
    let root = package.root_model_part()?;
    let mut out = Builder { path, vertices: Vec::new(), triangles: Vec::new() };
    package.load_part(&root, 0)?;
    let items = package.parts[&root].build.clone();
    if items.is_empty() {
        return Err(parse_error(path, None, format!("{root}: the model has no <build> items")));
    }
    // Count first, so that components that refer to one object many times cannot
    // make us allocate without bound.
    let (mut vertices, mut instances) = (0u64, 0u64);
    let mut memo = Counts::new();
    for item in &items {
        let part = item.path.clone().unwrap_or_else(|| root.clone());
        package.load_part(&part, 0)?;
        let (v, i) = package.count(&part, item.object, 0, &mut memo)?;
        vertices = vertices.saturating_add(v);
        instances = instances.saturating_add(i);
    }
    if vertices > u32::MAX as u64 || instances > MAX_INSTANCES {
        return Err(parse_error(
            path,
            None,
            format!("{root}: the build expands to {vertices} vertices in {instances} object instances"),
        ));
    }
    for item in &items {
        let part = item.path.clone().unwrap_or_else(|| root.clone());
        package.emit(&part, item.object, &item.transform, &mut out)?;
    }
    checked_mesh(path, out.vertices, out.triangles)
}

/// An affine map `p' = A p + t`, stored as the 3MF 4x3 matrix (rows m0*, m1*, m2*
/// are the images of the axes, row m3* the translation).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Transform([f64; 12]);

impl Transform {
    const IDENTITY: Self = Self([1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]);

    fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        let m = &self.0;
        std::array::from_fn(|c| p[0] * m[c] + p[1] * m[3 + c] + p[2] * m[6 + c] + m[9 + c])
    }

    /// `self` first, then `outer`.
    fn then(&self, outer: &Self) -> Self {
        let (a, b) = (&self.0, &outer.0);
        let mut m = [0.0; 12];
        for r in 0..4 {
            for c in 0..3 {
                m[3 * r + c] = (0..3).map(|k| a[3 * r + k] * b[3 * k + c]).sum::<f64>()
                    + if r == 3 { b[9 + c] } else { 0.0 };
            }
        }
        Self(m)
    }
}

#[derive(Debug, Clone)]
struct Ref {
    object: u64,
    /// The part of the object (production extension), when not the referring part.
    path: Option<String>,
    transform: Transform,
}

#[derive(Debug, Default)]
struct Object {
    /// `model` or `solidsupport`: part of the solid.
    solid: bool,
    vertices: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
    components: Vec<Ref>,
}

#[derive(Debug, Default)]
struct Part {
    objects: HashMap<u64, Object>,
    build: Vec<Ref>,
}

struct Builder<'a> {
    path: &'a Path,
    vertices: Vec<Point3>,
    triangles: Vec<[u32; 3]>,
}

struct Package<'a> {
    path: &'a Path,
    zip: ZipArchive<Cursor<&'a [u8]>>,
    parts: HashMap<String, Part>,
}

impl<'a> Package<'a> {
    fn open(bytes: &'a [u8], path: &'a Path) -> Result<Self> {
        let zip = ZipArchive::new(Cursor::new(bytes))
            .map_err(|e| parse_error(path, None, format!("not a 3MF package (a ZIP archive): {e}")))?;
        Ok(Self { path, zip, parts: HashMap::new() })
    }

    /// Reads a part by name (case-insensitive, as OPC part names are).
    fn read(&mut self, name: &str) -> Result<Option<Vec<u8>>> {
        let name = name.trim_start_matches('/');
        let Some(index) = (0..self.zip.len()).find(|&i| {
            self.zip.name_for_index(i).and_then(|n| n.ok()).is_some_and(|n| n.eq_ignore_ascii_case(name))
        }) else {
            return Ok(None);
        };
        let path = self.path;
        let err = |e: &dyn std::fmt::Display| parse_error(path, None, format!("{name}: {e}"));
        let file = self.zip.by_index(index).map_err(|e| err(&e))?;
        if file.size() > MAX_PART_BYTES {
            return Err(err(&format_args!("{} bytes uncompressed, more than we read", file.size())));
        }
        // The header's size is a claim, not a promise: reserve at most 64 MiB up front.
        let mut buf = Vec::with_capacity(file.size().min(1 << 26) as usize);
        file.take(MAX_PART_BYTES + 1).read_to_end(&mut buf).map_err(|e| err(&e))?;
        if buf.len() as u64 > MAX_PART_BYTES {
            return Err(err(&"the part is larger than its header says"));
        }
        Ok(Some(buf))
    }

    /// The model part the package relationships name (`3D/3dmodel.model` without them).
    fn root_model_part(&mut self) -> Result<String> {
        if let Some(rels) = self.read("_rels/.rels")? {
            let text = String::from_utf8_lossy(&rels);
            let mut scan = Scanner::new(&text);
            while let Some(tag) =
                scan.next_tag().map_err(|e| parse_error(self.path, None, format!("_rels/.rels: {e}")))?
            {
                if let Tag::Start { name: "Relationship", attrs, .. } = tag
                    && attr(&attrs, "Type") == Some(REL_3DMODEL)
                    && let Some(t) = attr(&attrs, "Target")
                {
                    return Ok(t.trim_start_matches('/').to_string());
                }
            }
        }
        if self.zip.is_empty() {
            return Err(parse_error(self.path, None, "not a 3MF package: the ZIP archive is empty"));
        }
        Ok(MODEL_PART.to_string())
    }

    fn load_part(&mut self, name: &str, depth: usize) -> Result<()> {
        if self.parts.contains_key(name) {
            return Ok(());
        }
        if depth > MAX_DEPTH {
            return Err(parse_error(self.path, None, format!("{name}: model parts nest too deep")));
        }
        let bytes = self.read(name)?.ok_or_else(|| {
            parse_error(self.path, None, format!("not a 3MF package: it has no model part {name}"))
        })?;
        let part = parse_model(&bytes, name).map_err(|e| parse_error(self.path, None, e))?;
        let referenced: Vec<String> = part
            .objects
            .values()
            .flat_map(|o| o.components.iter())
            .chain(&part.build)
            .filter_map(|r| r.path.clone())
            .collect();
        self.parts.insert(name.to_string(), part);
        for p in referenced {
            self.load_part(&p, depth + 1)?;
        }
        Ok(())
    }

    fn object(&self, part: &str, id: u64) -> Result<&Object> {
        self.parts
            .get(part)
            .and_then(|p| p.objects.get(&id))
            .ok_or_else(|| parse_error(self.path, None, format!("{part}: no object with id {id}")))
    }

    /// The vertices and the object instances object `id` expands to (its own and its
    /// components', recursively), memoised so that shared components cost once.
    fn count(&self, part: &str, id: u64, depth: usize, memo: &mut Counts) -> Result<(u64, u64)> {
        if let Some(&n) = memo.get(&(part.to_string(), id)) {
            return Ok(n);
        }
        if depth > MAX_DEPTH {
            return Err(parse_error(self.path, None, format!("{part}: components nest too deep (a cycle?)")));
        }
        let o = self.object(part, id)?;
        let (mut vertices, mut instances) = (if o.solid { o.vertices.len() as u64 } else { 0 }, 1u64);
        for c in &o.components {
            let (v, i) = self.count(c.path.as_deref().unwrap_or(part), c.object, depth + 1, memo)?;
            vertices = vertices.saturating_add(v);
            instances = instances.saturating_add(i);
        }
        memo.insert((part.to_string(), id), (vertices, instances));
        Ok((vertices, instances))
    }

    fn emit(&self, part: &str, id: u64, t: &Transform, out: &mut Builder<'_>) -> Result<()> {
        let o = self.object(part, id)?;
        if o.solid && !o.triangles.is_empty() {
            let base = out.vertices.len();
            out.vertices.extend(o.vertices.iter().map(|&p| Point3::from(t.apply(p))));
            let base = u32::try_from(base).map_err(|_| parse_error(out.path, None, "too many vertices"))?;
            out.triangles.extend(o.triangles.iter().map(|tri| tri.map(|v| v + base)));
        }
        for c in &o.components {
            let t = c.transform.then(t);
            self.emit(c.path.as_deref().unwrap_or(part), c.object, &t, out)?;
        }
        Ok(())
    }
}

/// Millimetres per model unit.
fn unit_scale(unit: &str) -> Option<f64> {
    Some(match unit {
        "micron" => 0.001,
        "millimeter" => 1.0,
        "centimeter" => 10.0,
        "inch" => 25.4,
        "foot" => 304.8,
        "meter" => 1000.0,
        _ => return None,
    })
}

/// Parses one model part; errors name the part and the line.
fn parse_model(bytes: &[u8], part: &str) -> std::result::Result<Part, String> {
    let text = std::str::from_utf8(bytes).map_err(|e| format!("{part}: not UTF-8 text ({e})"))?;
    let mut scan = Scanner::new(text);
    let at = |scan: &Scanner<'_>, msg: &dyn std::fmt::Display| format!("{part}:{}: {msg}", scan.line());
    let mut out = Part::default();
    let mut scale = None;
    // The object being read, and whether we are inside its <mesh>.
    let mut current: Option<(u64, Object)> = None;
    let mut in_mesh = false;
    let mut in_build = false;
    let mut in_components = false;
    loop {
        let tag = match scan.next_tag() {
            Ok(Some(t)) => t,
            Ok(None) => break,
            Err(e) => return Err(at(&scan, &e)),
        };
        match tag {
            Tag::Start { name, attrs, empty } => match name {
                "model" => {
                    let unit = attr(&attrs, "unit").unwrap_or("millimeter");
                    scale = Some(
                        unit_scale(unit).ok_or_else(|| at(&scan, &format_args!("unknown unit {unit:?}")))?,
                    );
                }
                "object" => {
                    let id = number_attr(&attrs, "id").map_err(|e| at(&scan, &e))?;
                    let ty = attr(&attrs, "type").unwrap_or("model");
                    let solid = matches!(ty, "model" | "solidsupport");
                    let object = Object { solid, ..Object::default() };
                    if empty {
                        if out.objects.insert(id, object).is_some() {
                            return Err(at(&scan, &format_args!("two objects with id {id}")));
                        }
                    } else {
                        current = Some((id, object));
                    }
                }
                "mesh" if current.is_some() => in_mesh = !empty,
                "components" if current.is_some() => in_components = !empty,
                "vertex" if in_mesh => {
                    let o = &mut current.as_mut().expect("in an object").1;
                    let mut p = [0.0; 3];
                    for (v, k) in p.iter_mut().zip(["x", "y", "z"]) {
                        *v = float_attr(&attrs, k).map_err(|e| at(&scan, &e))?;
                    }
                    o.vertices.push(p);
                }
                "triangle" if in_mesh => {
                    let (id, o) = current.as_mut().expect("in an object");
                    let mut t = [0u32; 3];
                    for (v, k) in t.iter_mut().zip(["v1", "v2", "v3"]) {
                        let i = number_attr(&attrs, k).map_err(|e| at(&scan, &e))?;
                        if i >= o.vertices.len() as u64 {
                            return Err(at(
                                &scan,
                                &format_args!(
                                    "object {id}: triangle {} refers to vertex {i}, but the object has {} vertices",
                                    o.triangles.len(),
                                    o.vertices.len()
                                ),
                            ));
                        }
                        *v = i as u32;
                    }
                    o.triangles.push(t);
                }
                "component" if in_components => {
                    let r = reference(&attrs).map_err(|e| at(&scan, &e))?;
                    current.as_mut().expect("in an object").1.components.push(r);
                }
                "build" => in_build = !empty,
                "item" if in_build => out.build.push(reference(&attrs).map_err(|e| at(&scan, &e))?),
                _ => {}
            },
            Tag::End { name } => match name {
                "object" => {
                    if let Some((id, o)) = current.take()
                        && out.objects.insert(id, o).is_some()
                    {
                        return Err(at(&scan, &format_args!("two objects with id {id}")));
                    }
                    in_mesh = false;
                    in_components = false;
                }
                "mesh" => in_mesh = false,
                "components" => in_components = false,
                "build" => in_build = false,
                _ => {}
            },
        }
    }
    let Some(scale) = scale else {
        return Err(format!("{part}: no <model> element"));
    };
    if current.is_some() {
        return Err(format!("{part}: the file ends inside an <object>"));
    }
    if scale != 1.0 {
        for o in out.objects.values_mut() {
            for p in &mut o.vertices {
                *p = p.map(|c| c * scale);
            }
        }
        for r in out.objects.values_mut().flat_map(|o| o.components.iter_mut()).chain(out.build.iter_mut()) {
            for c in &mut r.transform.0[9..] {
                *c *= scale;
            }
        }
    }
    Ok(out)
}

/// A build item or component: `objectid`, optional `transform` and `p:path`.
fn reference(attrs: &[(&str, &str)]) -> std::result::Result<Ref, String> {
    let object = number_attr(attrs, "objectid")?;
    let transform = match attr(attrs, "transform") {
        None => Transform::IDENTITY,
        Some(s) => {
            let v: Vec<f64> = s
                .split_ascii_whitespace()
                .map(str::parse)
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| format!("transform {s:?} is not 12 numbers"))?;
            let m: [f64; 12] = v.try_into().map_err(|_| format!("transform {s:?} is not 12 numbers"))?;
            if m.iter().any(|c| !c.is_finite()) {
                return Err(format!("transform {s:?} is not finite"));
            }
            Transform(m)
        }
    };
    let path = attr(attrs, "path").map(|p| p.trim_start_matches('/').to_string());
    Ok(Ref { object, path, transform })
}

fn attr<'a>(attrs: &[(&str, &'a str)], key: &str) -> Option<&'a str> {
    attrs.iter().find(|(k, _)| *k == key).map(|(_, v)| *v)
}

fn number_attr(attrs: &[(&str, &str)], key: &str) -> std::result::Result<u64, String> {
    let v = attr(attrs, key).ok_or_else(|| format!("missing attribute {key}"))?;
    v.trim().parse().map_err(|_| format!("attribute {key}={v:?} is not a non-negative integer"))
}

fn float_attr(attrs: &[(&str, &str)], key: &str) -> std::result::Result<f64, String> {
    let v = attr(attrs, key).ok_or_else(|| format!("missing attribute {key}"))?;
    match v.trim().parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!("attribute {key}={v:?} is not a finite number")),
    }
}

/// One XML tag; names and attribute keys without their namespace prefix.
#[derive(Debug)]
enum Tag<'a> {
    Start {
        name: &'a str,
        attrs: Vec<(&'a str, &'a str)>,
        /// `<a/>`: no content and no end tag follow.
        empty: bool,
    },
    End {
        name: &'a str,
    },
}

/// A forward scanner over the tags of an XML document. Text, comments, processing
/// instructions, CDATA and declarations are skipped; `<a/>` gives a start tag only.
struct Scanner<'a> {
    text: &'a str,
    pos: usize,
}

impl<'a> Scanner<'a> {
    fn new(text: &'a str) -> Self {
        Self { text: text.strip_prefix('\u{feff}').unwrap_or(text), pos: 0 }
    }

    /// The 1-based line of the scanner's position.
    fn line(&self) -> usize {
        1 + self.text.as_bytes()[..self.pos].iter().filter(|&&b| b == b'\n').count()
    }

    fn skip_past(&mut self, end: &str, what: &str) -> std::result::Result<(), String> {
        match self.text[self.pos..].find(end) {
            Some(i) => {
                self.pos += i + end.len();
                Ok(())
            }
            None => Err(format!("unterminated {what}")),
        }
    }

    fn next_tag(&mut self) -> std::result::Result<Option<Tag<'a>>, String> {
        loop {
            let Some(i) = self.text[self.pos..].find('<') else {
                self.pos = self.text.len();
                return Ok(None);
            };
            self.pos += i;
            let rest = &self.text[self.pos..];
            if rest.starts_with("<?") {
                self.skip_past("?>", "processing instruction")?;
            } else if rest.starts_with("<!--") {
                self.skip_past("-->", "comment")?;
            } else if rest.starts_with("<![CDATA[") {
                self.skip_past("]]>", "CDATA section")?;
            } else if rest.starts_with("<!") {
                self.skip_past(">", "declaration")?;
            } else {
                return self.tag().map(Some);
            }
        }
    }

    fn tag(&mut self) -> std::result::Result<Tag<'a>, String> {
        let text = self.text;
        let b = text.as_bytes();
        let mut i = self.pos + 1;
        let end_tag = b.get(i) == Some(&b'/');
        if end_tag {
            i += 1;
        }
        let start = i;
        while i < b.len() && !b[i].is_ascii_whitespace() && !matches!(b[i], b'>' | b'/') {
            i += 1;
        }
        if i == start {
            return Err("a tag without a name".into());
        }
        let name = local(&text[start..i]);
        let mut attrs = Vec::new();
        let mut empty = false;
        loop {
            while i < b.len() && b[i].is_ascii_whitespace() {
                i += 1;
            }
            match b.get(i) {
                None => return Err(format!("the file ends inside <{name}>")),
                Some(b'>') => {
                    i += 1;
                    break;
                }
                Some(b'/') if b.get(i + 1) == Some(&b'>') => {
                    i += 2;
                    empty = true;
                    break;
                }
                Some(_) if end_tag => return Err(format!("malformed end tag </{name}")),
                Some(_) => {
                    let k0 = i;
                    while i < b.len() && !b[i].is_ascii_whitespace() && !matches!(b[i], b'=' | b'>' | b'/') {
                        i += 1;
                    }
                    let key = &text[k0..i];
                    while i < b.len() && b[i].is_ascii_whitespace() {
                        i += 1;
                    }
                    if b.get(i) != Some(&b'=') {
                        self.pos = i.min(b.len());
                        return Err(format!("<{name}>: attribute {key:?} has no value"));
                    }
                    i += 1;
                    while i < b.len() && b[i].is_ascii_whitespace() {
                        i += 1;
                    }
                    let quote = match b.get(i) {
                        Some(&q @ (b'"' | b'\'')) => q,
                        _ => {
                            self.pos = i.min(b.len());
                            return Err(format!("<{name}>: attribute {key:?} is not quoted"));
                        }
                    };
                    let v0 = i + 1;
                    let Some(len) = b[v0..].iter().position(|&c| c == quote) else {
                        return Err(format!("<{name}>: attribute {key:?} is not closed"));
                    };
                    attrs.push((local(key), &text[v0..v0 + len]));
                    i = v0 + len + 1;
                }
            }
        }
        self.pos = i;
        Ok(if end_tag { Tag::End { name } } else { Tag::Start { name, attrs, empty } })
    }
}

/// A name without its namespace prefix.
fn local(name: &str) -> &str {
    name.rsplit_once(':').map_or(name, |(_, l)| l)
}
