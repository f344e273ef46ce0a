#!/usr/bin/env python3
"""Independent reader and checker of a defectgen dataset folder.

It shares no code with the C++ writers: the PNG decoder follows the PNG specification (W3C,
"Portable Network Graphics (PNG) Specification", 2nd ed., sections 5 (datastream), 7 (encoding),
9 (filtering) and 11.2.2 (IHDR)), and the RLE decoder follows the COCO data format description
(https://cocodataset.org/#format-data) and the convention of the reference cocoapi: counts
alternate background/foreground runs, begin with a (possibly empty) background run, and walk the
image in column-major order (down each column, columns left to right).

Python 3 standard library only.

Use:
    python3 coco_reader.py --selftest       # checks the decoders on data built here
    python3 coco_reader.py OUT_DIR          # checks a dataset, prints a JSON summary
From other tests:
    from coco_reader import check_dataset, read_png, rle_decode
"""

import json
import os
import re
import struct
import sys
import tempfile
import zlib

# --------------------------------------------------------------------------------------------
# PNG decoding

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"

# (colour type, bit depth) -> samples per pixel. Colour type 0 is greyscale, 2 is truecolour.
_SUPPORTED = {(0, 8): 1, (0, 16): 1, (2, 8): 3, (2, 16): 3}


def _chunks(data, name):
    """Yields (type, payload) of every chunk, checking lengths and CRCs."""
    if data[:8] != PNG_SIGNATURE:
        raise ValueError("%s: not a PNG file (bad signature)" % name)
    pos = 8
    while True:
        if pos + 12 > len(data):
            raise ValueError("%s: truncated chunk at byte %d" % (name, pos))
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        ctype = data[pos + 4:pos + 8]
        end = pos + 8 + length
        if end + 4 > len(data):
            raise ValueError("%s: chunk %r runs past the end of the file" % (name, ctype))
        payload = data[pos + 8:end]
        (crc,) = struct.unpack(">I", data[end:end + 4])
        if zlib.crc32(ctype + payload) & 0xFFFFFFFF != crc:
            raise ValueError("%s: CRC mismatch in chunk %r" % (name, ctype))
        yield ctype, payload
        pos = end + 4
        if ctype == b"IEND":
            return


def _parse_ihdr(payload, name):
    if len(payload) != 13:
        raise ValueError("%s: IHDR has length %d, expected 13" % (name, len(payload)))
    width, height, depth, ctype, comp, filt, interlace = struct.unpack(">IIBBBBB", payload)
    if width == 0 or height == 0:
        raise ValueError("%s: zero image size %dx%d" % (name, width, height))
    if (ctype, depth) not in _SUPPORTED:
        raise ValueError("%s: unsupported colour type %d with bit depth %d" % (name, ctype, depth))
    if comp != 0 or filt != 0:
        raise ValueError("%s: unknown compression (%d) or filter method (%d)" % (name, comp, filt))
    if interlace != 0:
        raise ValueError("%s: interlaced PNGs are not supported" % name)
    return width, height, depth, ctype


def png_header(path):
    """Width, height, bit depth and colour type of a PNG, reading only its IHDR chunk."""
    with open(path, "rb") as f:
        head = f.read(33)  # signature (8) + length (4) + "IHDR" (4) + payload (13) + CRC (4)
    if head[:8] != PNG_SIGNATURE:
        raise ValueError("%s: not a PNG file (bad signature)" % path)
    if len(head) < 33 or head[8:16] != struct.pack(">I", 13) + b"IHDR":
        raise ValueError("%s: first chunk is not a 13-byte IHDR" % path)
    (crc,) = struct.unpack(">I", head[29:33])
    if zlib.crc32(head[12:29]) & 0xFFFFFFFF != crc:
        raise ValueError("%s: CRC mismatch in IHDR" % path)
    w, h, depth, ctype = _parse_ihdr(head[16:29], path)
    return {"width": w, "height": h, "bit_depth": depth, "color_type": ctype}


def _paeth(a, b, c):
    # PNG spec 9.4: predictor closest to a + b - c, ties broken in the order a, b, c.
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    if pa <= pb and pa <= pc:
        return a
    if pb <= pc:
        return b
    return c


def _unfilter(raw, width, height, bpp, name):
    """Reverses the per-scanline filters; returns (bytes of all rows, set of filter types)."""
    stride = width * bpp
    if len(raw) != height * (stride + 1):
        raise ValueError("%s: decompressed size %d, expected %d" %
                         (name, len(raw), height * (stride + 1)))
    out = bytearray()
    prev = bytearray(stride)  # the row above the first one counts as zeros
    used = set()
    for y in range(height):
        start = y * (stride + 1)
        ftype = raw[start]
        line = bytearray(raw[start + 1:start + 1 + stride])
        used.add(ftype)
        if ftype == 0:  # None
            pass
        elif ftype == 1:  # Sub: add the byte bpp to the left
            for i in range(bpp, stride):
                line[i] = (line[i] + line[i - bpp]) & 0xFF
        elif ftype == 2:  # Up: add the byte above
            line = bytearray((v + u) & 0xFF for v, u in zip(line, prev))
        elif ftype == 3:  # Average: add floor((left + above) / 2)
            for i in range(stride):
                left = line[i - bpp] if i >= bpp else 0
                line[i] = (line[i] + ((left + prev[i]) >> 1)) & 0xFF
        elif ftype == 4:  # Paeth
            for i in range(stride):
                if i >= bpp:
                    left, upleft = line[i - bpp], prev[i - bpp]
                else:
                    left, upleft = 0, 0
                line[i] = (line[i] + _paeth(left, prev[i], upleft)) & 0xFF
        else:
            raise ValueError("%s: row %d has unknown filter type %d" % (name, y, ftype))
        out += line
        prev = line
    return bytes(out), used


def decode_png(data, name="<png>"):
    """Decodes PNG bytes (greyscale or RGB, 8 or 16 bit, not interlaced).

    Returns a dict: width, height, bit_depth, color_type, channels, filters (set of filter types
    seen), and pixels: a flat row-major list of integer samples, channels interleaved (16-bit
    samples are big-endian in the file and returned as plain ints)."""
    header = None
    idat = []
    seen_iend = False
    for ctype, payload in _chunks(data, name):
        if ctype == b"IHDR":
            if header is not None:
                raise ValueError("%s: two IHDR chunks" % name)
            header = _parse_ihdr(payload, name)
        elif header is None:
            raise ValueError("%s: first chunk is %r, expected IHDR" % (name, ctype))
        elif ctype == b"IDAT":
            idat.append(payload)
        elif ctype == b"IEND":
            seen_iend = True
        elif ctype == b"PLTE":
            pass  # only a suggested palette for truecolour; greyscale must not have one
        elif not (ctype[0] & 0x20):  # upper-case first letter: critical chunk we do not know
            raise ValueError("%s: unknown critical chunk %r" % (name, ctype))
    if header is None or not seen_iend or not idat:
        raise ValueError("%s: missing IHDR, IDAT or IEND" % name)
    width, height, depth, ctype = header
    channels = _SUPPORTED[(ctype, depth)]
    bpp = channels * depth // 8
    try:
        raw = zlib.decompress(b"".join(idat))
    except zlib.error as e:
        raise ValueError("%s: bad zlib stream: %s" % (name, e))
    rows, used = _unfilter(raw, width, height, bpp, name)
    if depth == 8:
        pixels = list(rows)
    else:
        pixels = list(struct.unpack(">%dH" % (len(rows) // 2), rows))
    return {"width": width, "height": height, "bit_depth": depth, "color_type": ctype,
            "channels": channels, "filters": used, "pixels": pixels}


def read_png(path):
    with open(path, "rb") as f:
        return decode_png(f.read(), path)


# --------------------------------------------------------------------------------------------
# COCO RLE

def _check_counts(counts, height, width):
    total = 0
    for c in counts:
        if not isinstance(c, int) or isinstance(c, bool) or c < 0:
            raise ValueError("RLE counts must be non-negative integers, got %r" % (c,))
        total += c
    if total != height * width:
        raise ValueError("RLE counts sum to %d, expected height*width = %d" %
                         (total, height * width))


def rle_foreground(counts, height, width):
    """Uncompressed COCO RLE -> sorted row-major indices (y * width + x) of the set pixels."""
    _check_counts(counts, height, width)
    ones = []
    k = 0  # position in column-major order: k = x * height + y
    for run, c in enumerate(counts):
        if run % 2 == 1:
            for j in range(k, k + c):
                x, y = divmod(j, height)
                ones.append(y * width + x)
        k += c
    ones.sort()
    return ones


def rle_decode(counts, height, width):
    """Uncompressed COCO RLE -> row-major list of 0/1 of length height * width."""
    mask = [0] * (height * width)
    for i in rle_foreground(counts, height, width):
        mask[i] = 1
    return mask


# --------------------------------------------------------------------------------------------
# Dataset check

DEFECTGEN_CATEGORIES = {1: "dent", 2: "scratch", 3: "rust", 4: "patina"}


def _fail(msg):
    raise AssertionError(msg)


def _is_int(v):
    return isinstance(v, int) and not isinstance(v, bool)


def _require(obj, key, kind, where):
    if not isinstance(obj, dict):
        _fail("%s: expected a JSON object, got %s" % (where, type(obj).__name__))
    if key not in obj:
        _fail("%s: missing key %r" % (where, key))
    v = obj[key]
    ok = {"int": _is_int(v), "str": isinstance(v, str), "list": isinstance(v, list),
          "dict": isinstance(v, dict)}[kind]
    if not ok:
        _fail("%s: %r must be %s, got %r" % (where, key, kind, v))
    return v


def _validate_schema(doc, expected_categories):
    if not isinstance(doc, dict):
        _fail("annotations.json: top level must be an object")
    images = _require(doc, "images", "list", "annotations.json")
    anns = _require(doc, "annotations", "list", "annotations.json")
    cats = _require(doc, "categories", "list", "annotations.json")

    cat_by_id = {}
    for i, c in enumerate(cats):
        where = "categories[%d]" % i
        cid = _require(c, "id", "int", where)
        name = _require(c, "name", "str", where)
        _require(c, "supercategory", "str", where)
        if cid < 1:
            _fail("%s: id %d must be >= 1 (0 is background)" % (where, cid))
        if cid in cat_by_id:
            _fail("%s: duplicate category id %d" % (where, cid))
        cat_by_id[cid] = name
    if expected_categories is not None and cat_by_id != expected_categories:
        _fail("categories are %r, expected %r" % (cat_by_id, expected_categories))

    img_by_id = {}
    names = set()
    for i, im in enumerate(images):
        where = "images[%d]" % i
        iid = _require(im, "id", "int", where)
        fname = _require(im, "file_name", "str", where)
        w = _require(im, "width", "int", where)
        h = _require(im, "height", "int", where)
        if w < 1 or h < 1:
            _fail("%s: size %dx%d must be positive" % (where, w, h))
        if iid in img_by_id:
            _fail("%s: duplicate image id %d" % (where, iid))
        if fname in names:
            _fail("%s: duplicate file_name %r" % (where, fname))
        m = re.fullmatch(r"images/(\d{6,})\.png", fname)
        if not m:
            _fail("%s: file_name %r is not images/NNNNNN.png" % (where, fname))
        if int(m.group(1)) != iid:
            _fail("%s: id %d does not match file_name %r" % (where, iid, fname))
        names.add(fname)
        img_by_id[iid] = im

    ann_ids = set()
    for i, a in enumerate(anns):
        where = "annotations[%d]" % i
        aid = _require(a, "id", "int", where)
        image_id = _require(a, "image_id", "int", where)
        cid = _require(a, "category_id", "int", where)
        seg = _require(a, "segmentation", "dict", where)
        area = _require(a, "area", "int", where)
        bbox = _require(a, "bbox", "list", where)
        iscrowd = _require(a, "iscrowd", "int", where)
        inst = _require(a, "instance_id", "int", where)
        _require(a, "attributes", "dict", where)
        where = "annotation id %s" % aid
        if aid < 1:
            _fail("%s: ids must be >= 1 (pycocotools' COCOeval reads 0 as unmatched)" % where)
        if aid in ann_ids:
            _fail("%s: duplicate annotation id" % where)
        ann_ids.add(aid)
        if image_id not in img_by_id:
            _fail("%s: image_id %d is not in images" % (where, image_id))
        if cid not in cat_by_id:
            _fail("%s: category_id %d is not in categories" % (where, cid))
        if iscrowd != 0:
            _fail("%s: iscrowd is %d, expected 0" % (where, iscrowd))
        if inst < 1 or inst > 65535:
            _fail("%s: instance_id %d outside 1..65535" % (where, inst))
        if area < 1:
            _fail("%s: area %d must be positive" % (where, area))
        if len(bbox) != 4 or not all(_is_int(v) for v in bbox):
            _fail("%s: bbox %r must be 4 integers" % (where, bbox))
        if set(seg.keys()) != {"size", "counts"}:
            _fail("%s: segmentation keys %r, expected size and counts" % (where, sorted(seg)))
        im = img_by_id[image_id]
        size = seg["size"]
        if not (isinstance(size, list) and len(size) == 2 and all(_is_int(v) for v in size)):
            _fail("%s: segmentation size %r must be [height, width]" % (where, size))
        if size != [im["height"], im["width"]]:
            _fail("%s: segmentation size %r != [height, width] = [%d, %d] of image %d" %
                  (where, size, im["height"], im["width"], image_id))
        counts = seg["counts"]
        if not isinstance(counts, list) or not counts:
            _fail("%s: counts must be a non-empty list (uncompressed RLE)" % where)
        for j, c in enumerate(counts):
            if not _is_int(c) or c < 0:
                _fail("%s: counts[%d] = %r is not a non-negative integer" % (where, j, c))
            if j > 0 and c == 0:
                _fail("%s: counts[%d] is 0; only the first run may be empty" % (where, j))
        if sum(counts) != size[0] * size[1]:
            _fail("%s: sum(counts) = %d != h*w = %d" % (where, sum(counts), size[0] * size[1]))
    return img_by_id, cat_by_id, anns


def _first_difference(rle_px, mask_px, width):
    a, b = set(rle_px), set(mask_px)
    i = min(a ^ b)
    return "pixel (x=%d, y=%d), set in the %s only" % (i % width, i // width,
                                                     "RLE" if i in a else "instance mask")


def check_dataset(out_dir, expected_categories=DEFECTGEN_CATEGORIES):
    """Checks out_dir/annotations.json against the masks in out_dir/masks.

    Raises AssertionError naming the first mismatch; returns a summary dict."""
    path = os.path.join(out_dir, "annotations.json")
    with open(path, "r", encoding="utf-8") as f:
        doc = json.load(f)
    img_by_id, cat_by_id, anns = _validate_schema(doc, expected_categories)

    by_image = {iid: [] for iid in img_by_id}
    for a in anns:
        by_image[a["image_id"]].append(a)

    per_category = {name: 0 for name in cat_by_id.values()}
    labeled = 0
    checked = 0
    for iid in sorted(img_by_id):
        im = img_by_id[iid]
        w, h = im["width"], im["height"]
        stem = os.path.basename(im["file_name"])[:-4]
        img_path = os.path.join(out_dir, im["file_name"])
        if not os.path.isfile(img_path):
            _fail("image %d: %s does not exist" % (iid, img_path))
        hdr = png_header(img_path)
        if (hdr["width"], hdr["height"]) != (w, h) or hdr["color_type"] != 2:
            _fail("image %d: %s is %dx%d colour type %d, expected %dx%d RGB" %
                  (iid, img_path, hdr["width"], hdr["height"], hdr["color_type"], w, h))

        inst = read_png(os.path.join(out_dir, "masks", stem + "_instance.png"))
        sem = read_png(os.path.join(out_dir, "masks", stem + "_semantic.png"))
        for m, kind, depth in ((inst, "instance", 16), (sem, "semantic", 8)):
            if (m["width"], m["height"], m["color_type"], m["bit_depth"]) != (w, h, 0, depth):
                _fail("image %d: %s mask is %dx%d colour type %d, %d-bit; expected %dx%d "
                      "greyscale %d-bit" % (iid, kind, m["width"], m["height"], m["color_type"],
                                            m["bit_depth"], w, h, depth))
        ipx, spx = inst["pixels"], sem["pixels"]

        pixels_of = {}  # instance id -> row-major indices of its pixels, ascending
        for i, v in enumerate(ipx):
            if v:
                pixels_of.setdefault(v, []).append(i)
        ann_ids = [a["instance_id"] for a in by_image[iid]]
        if len(set(ann_ids)) != len(ann_ids):
            _fail("image %d: an instance_id is annotated twice: %r" % (iid, sorted(ann_ids)))
        if set(ann_ids) != set(pixels_of):
            _fail("image %d: instance ids in the mask %r differ from annotated ids %r" %
                  (iid, sorted(pixels_of), sorted(ann_ids)))

        for a in by_image[iid]:
            where = "image %d, annotation %d (instance %d)" % (iid, a["id"], a["instance_id"])
            ones = rle_foreground(a["segmentation"]["counts"], h, w)
            if ones != pixels_of[a["instance_id"]]:
                _fail("%s: RLE differs from instance mask at %s" %
                      (where, _first_difference(ones, pixels_of[a["instance_id"]], w)))
            xs = [i % w for i in ones]
            ys = [i // w for i in ones]
            if a["area"] != len(ones):
                _fail("%s: area %d != mask pixel count %d" % (where, a["area"], len(ones)))
            box = [min(xs), min(ys), max(xs) - min(xs) + 1, max(ys) - min(ys) + 1]
            if a["bbox"] != box:
                _fail("%s: bbox %r != tight box %r" % (where, a["bbox"], box))
            cid = a["category_id"]
            for i in ones:
                if spx[i] != cid:
                    _fail("%s: semantic mask is %d at (x=%d, y=%d), expected category %d" %
                          (where, spx[i], i % w, i // w, cid))
            per_category[cat_by_id[cid]] += 1
            labeled += len(ones)
        for i, v in enumerate(ipx):
            if v == 0 and spx[i] != 0:
                _fail("image %d: semantic mask is %d at background pixel (x=%d, y=%d)" %
                      (iid, spx[i], i % w, i // w))
        checked += w * h

    return {"images": len(img_by_id), "annotations": len(anns), "categories": len(cat_by_id),
            "annotations_per_category": per_category, "pixels_labeled": labeled,
            "pixels_checked": checked}


# --------------------------------------------------------------------------------------------
# Self-test. The encoder below exists only to feed the decoder; it applies the filters forward.

def _filter_row(ftype, line, prev, bpp):
    out = bytearray(len(line))
    for i in range(len(line)):
        a = line[i - bpp] if i >= bpp else 0
        b = prev[i]
        c = prev[i - bpp] if i >= bpp else 0
        pred = {0: 0, 1: a, 2: b, 3: (a + b) // 2, 4: _paeth(a, b, c)}[ftype]
        out[i] = (line[i] - pred) & 0xFF
    return out


def _encode_png(width, height, depth, ctype, samples, filters):
    """samples: row-major interleaved ints; filters: one filter type per row."""
    channels = _SUPPORTED[(ctype, depth)]
    bpp = channels * depth // 8
    if depth == 8:
        data = bytes(samples)
    else:
        data = struct.pack(">%dH" % len(samples), *samples)
    stride = width * bpp
    raw = bytearray()
    prev = bytearray(stride)
    for y in range(height):
        line = data[y * stride:(y + 1) * stride]
        raw.append(filters[y])
        raw += _filter_row(filters[y], line, prev, bpp)
        prev = line

    def chunk(t, p):
        return struct.pack(">I", len(p)) + t + p + struct.pack(">I", zlib.crc32(t + p) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", width, height, depth, ctype, 0, 0, 0)
    comp = zlib.compress(bytes(raw), 9)
    # Split IDAT in two to exercise concatenation, and add an ancillary chunk to be skipped.
    half = len(comp) // 2
    return (PNG_SIGNATURE + chunk(b"IHDR", ihdr) + chunk(b"tEXt", b"Comment\x00selftest") +
            chunk(b"IDAT", comp[:half]) + chunk(b"IDAT", comp[half:]) + chunk(b"IEND", b""))


def _selftest_png():
    width, height = 7, 5
    for ctype, depth in sorted(_SUPPORTED):
        channels = _SUPPORTED[(ctype, depth)]
        top = (1 << depth) - 1
        # Values that make every predictor matter: gradients, wrap-around, extremes.
        samples = [((x * 37 + y * 101 + c * 59) * (257 if depth == 16 else 1) + x * y * 13) % (top + 1)
                   for y in range(height) for x in range(width) for c in range(channels)]
        samples[0] = top
        samples[-1] = 0
        cases = [[f] * height for f in range(5)] + [[y % 5 for y in range(height)]]
        for filters in cases:
            png = _encode_png(width, height, depth, ctype, samples, filters)
            img = decode_png(png, "selftest")
            assert (img["width"], img["height"], img["bit_depth"], img["color_type"]) == \
                (width, height, depth, ctype)
            assert img["filters"] == set(filters), (img["filters"], filters)
            assert img["pixels"] == samples, \
                "colour type %d, %d-bit, filters %r: decoded pixels differ" % (ctype, depth, filters)
    # Corruption is reported, not decoded into garbage.
    png = bytearray(_encode_png(2, 2, 8, 0, [1, 2, 3, 4], [0, 0]))
    png[-20] ^= 0xFF
    try:
        decode_png(bytes(png), "corrupt")
    except ValueError:
        pass
    else:
        raise AssertionError("a corrupted PNG was accepted")


def _selftest_rle():
    # w=3, h=2 mask (rows): [1 0 0], [1 1 0]. Column-major walk: 1,1,0,1,0,0 -> [0,2,1,1,2].
    assert rle_decode([0, 2, 1, 1, 2], 2, 3) == [1, 0, 0, 1, 1, 0]
    # w=2, h=3 rows [0 1],[0 1],[1 0]: column-major 0,0,1,1,1,0 -> [2,3,1].
    assert rle_decode([2, 3, 1], 3, 2) == [0, 1, 0, 1, 1, 0]
    assert rle_decode([12], 3, 4) == [0] * 12
    assert rle_decode([0, 12], 3, 4) == [1] * 12
    try:
        rle_decode([1, 2], 2, 2)
    except ValueError:
        pass
    else:
        raise AssertionError("counts with a wrong sum were accepted")


def _write_tiny_dataset(root, inst_rows, sem_rows, anns):
    os.makedirs(os.path.join(root, "images"))
    os.makedirs(os.path.join(root, "masks"))
    h, w = len(inst_rows), len(inst_rows[0])
    rgb = [v for _ in range(h * w) for v in (10, 20, 30)]
    files = {"images/000003.png": (8, 2, rgb),
             "masks/000003_instance.png": (16, 0, [v for r in inst_rows for v in r]),
             "masks/000003_semantic.png": (8, 0, [v for r in sem_rows for v in r])}
    for rel, (depth, ctype, px) in files.items():
        with open(os.path.join(root, rel), "wb") as f:
            f.write(_encode_png(w, h, depth, ctype, px, [y % 5 for y in range(h)]))
    doc = {"images": [{"id": 3, "file_name": "images/000003.png", "width": w, "height": h}],
           "annotations": anns,
           "categories": [{"id": k, "name": v, "supercategory": "defect"}
                          for k, v in sorted(DEFECTGEN_CATEGORIES.items())]}
    with open(os.path.join(root, "annotations.json"), "w") as f:
        json.dump(doc, f)


def _selftest_dataset():
    # 4 wide, 3 high; instance 2 (rust) and instance 5 (dent).
    inst = [[0, 2, 2, 0],
            [0, 0, 2, 5],
            [0, 0, 0, 5]]
    sem = [[0, 3, 3, 0],
           [0, 0, 3, 1],
           [0, 0, 0, 1]]

    def ann(aid, inst_id, cat, counts, area, bbox):
        return {"id": aid, "image_id": 3, "category_id": cat,
                "segmentation": {"size": [3, 4], "counts": counts}, "area": area, "bbox": bbox,
                "iscrowd": 0, "instance_id": inst_id, "attributes": {}}

    # Instance 2, column-major: col0 000, col1 100, col2 110, col3 000 -> [3,1,2,2,4].
    # Instance 5: col3 = 0,1,1 -> 10 zeros, then 2 ones -> [10, 2].
    good = [ann(1, 2, 3, [3, 1, 2, 2, 4], 3, [1, 0, 2, 2]),
            ann(2, 5, 1, [10, 2], 2, [3, 1, 1, 2])]
    with tempfile.TemporaryDirectory() as d:
        _write_tiny_dataset(os.path.join(d, "ok"), inst, sem, good)
        hdr = png_header(os.path.join(d, "ok", "images", "000003.png"))
        assert hdr == {"width": 4, "height": 3, "bit_depth": 8, "color_type": 2}, hdr
        s = check_dataset(os.path.join(d, "ok"))
        assert s["annotations"] == 2 and s["pixels_labeled"] == 5, s
        assert s["annotations_per_category"]["rust"] == 1, s

        def must_fail(tag, anns, inst_rows=inst, sem_rows=sem, expect=""):
            root = os.path.join(d, tag)
            _write_tiny_dataset(root, inst_rows, sem_rows, anns)
            try:
                check_dataset(root)
            except AssertionError as e:
                assert expect in str(e), "%s: unexpected message %s" % (tag, e)
                return
            raise AssertionError("selftest: broken dataset '%s' passed the check" % tag)

        bad_bbox = [dict(good[0], bbox=[1, 0, 2, 3]), good[1]]
        must_fail("bbox", bad_bbox, expect="bbox")
        must_fail("area", [dict(good[0], area=4), good[1]], expect="area")
        transposed = dict(good[0], segmentation={"size": [3, 4], "counts": [1, 2, 2, 1, 6]})
        must_fail("rle", [transposed, good[1]], expect="RLE differs")
        must_fail("size", [dict(good[0], segmentation={"size": [4, 3],
                                                       "counts": [3, 1, 2, 2, 4]}), good[1]],
                  expect="size")
        must_fail("crowd", [dict(good[0], iscrowd=1), good[1]], expect="iscrowd")
        must_fail("missing", [good[0]], expect="differ from annotated ids")
        must_fail("floatarea", [dict(good[0], area=3.0), good[1]], expect="'area'")
        sem_bad = [r[:] for r in sem]
        sem_bad[2][0] = 4
        must_fail("sembg", good, sem_rows=sem_bad, expect="background pixel")
        sem_bad = [r[:] for r in sem]
        sem_bad[1][3] = 2
        must_fail("semcls", good, sem_rows=sem_bad, expect="semantic mask is 2")
        must_fail("dupid", [good[0], dict(good[1], id=1)], expect="duplicate")


def selftest():
    _selftest_png()
    _selftest_rle()
    _selftest_dataset()
    print("coco_reader selftest: OK")


def main(argv):
    if len(argv) == 2 and argv[1] == "--selftest":
        selftest()
        return 0
    if len(argv) == 2 and not argv[1].startswith("-"):
        print(json.dumps(check_dataset(argv[1]), indent=2, sort_keys=True))
        return 0
    sys.stderr.write("usage: coco_reader.py --selftest | coco_reader.py OUT_DIR\n")
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))
