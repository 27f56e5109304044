//! Every struct shared with GLSL has the layout the compiled SPIR-V declares, and every shader
//! passes `spirv-val` for Vulkan 1.3.

use ispm::gpu::shader_table;
use ispm::layout::SHARED_LAYOUTS;
use std::collections::HashMap;

const OP_NAME: u32 = 5;
const OP_MEMBER_NAME: u32 = 6;
const OP_MEMBER_DECORATE: u32 = 72;
const DECORATION_OFFSET: u32 = 35;

fn string(words: &[u32]) -> String {
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    String::from_utf8_lossy(&bytes[..end]).into_owned()
}

/// Struct name → member name → byte offset, for every struct type that carries explicit
/// offsets (block members) in `spirv`.
fn struct_offsets(spirv: &[u32]) -> HashMap<String, HashMap<String, u32>> {
    let mut names: HashMap<u32, String> = HashMap::new();
    let mut member_names: HashMap<(u32, u32), String> = HashMap::new();
    let mut offsets: Vec<(u32, u32, u32)> = Vec::new();
    let mut i = 5;
    while i < spirv.len() {
        let count = (spirv[i] >> 16) as usize;
        let op = spirv[i] & 0xffff;
        assert!(count > 0, "malformed SPIR-V");
        let ins = &spirv[i..i + count];
        match op {
            OP_NAME => {
                names.insert(ins[1], string(&ins[2..]));
            }
            OP_MEMBER_NAME => {
                member_names.insert((ins[1], ins[2]), string(&ins[3..]));
            }
            OP_MEMBER_DECORATE if ins[3] == DECORATION_OFFSET => {
                offsets.push((ins[1], ins[2], ins[4]));
            }
            _ => {}
        }
        i += count;
    }
    let mut out: HashMap<String, HashMap<String, u32>> = HashMap::new();
    for (ty, member, offset) in offsets {
        let (Some(ty_name), Some(member_name)) = (names.get(&ty), member_names.get(&(ty, member)))
        else {
            continue;
        };
        out.entry(ty_name.clone())
            .or_default()
            .insert(member_name.clone(), offset);
    }
    out
}

#[test]
fn every_shared_struct_matches_the_offsets_its_glsl_twin_compiles_to() {
    let mut checked: HashMap<&str, usize> = HashMap::new();
    for shader in shader_table::ALL {
        let found = struct_offsets(shader.spirv);
        for layout in SHARED_LAYOUTS {
            let Some(members) = found.get(layout.name) else {
                continue;
            };
            for (name, offset) in layout.members {
                let glsl = members.get(*name).unwrap_or_else(|| {
                    panic!(
                        "{}: GLSL struct {} has no member {name}",
                        shader.name, layout.name
                    )
                });
                assert_eq!(
                    *glsl as usize, *offset,
                    "{}: {}.{name} is at {glsl} in GLSL but {offset} in Rust",
                    shader.name, layout.name
                );
            }
            assert_eq!(
                members.len(),
                layout.members.len(),
                "{}: {} has members {:?} in GLSL",
                shader.name,
                layout.name,
                members.keys().collect::<Vec<_>>()
            );
            *checked.entry(layout.name).or_default() += 1;
        }
    }
    for layout in SHARED_LAYOUTS {
        assert!(
            checked.contains_key(layout.name),
            "no shader uses {} with explicit offsets, so its layout is unchecked",
            layout.name
        );
    }
}

#[test]
fn every_shader_passes_spirv_val_for_vulkan_1_3() {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("spirv-val");
    std::fs::create_dir_all(&dir).expect("temp dir");
    assert!(!shader_table::ALL.is_empty(), "no shaders compiled");
    for shader in shader_table::ALL {
        let path = dir.join(shader.name.replace('/', "_") + ".spv");
        let bytes: Vec<u8> = shader.spirv.iter().flat_map(|w| w.to_le_bytes()).collect();
        std::fs::write(&path, bytes).expect("write spv");
        let out = std::process::Command::new("spirv-val")
            .args(["--target-env", "vulkan1.3"])
            .arg(&path)
            .output()
            .expect("spirv-val (Debian/Ubuntu package spirv-tools) must be installed");
        assert!(
            out.status.success(),
            "{} fails spirv-val:\n{}",
            shader.name,
            String::from_utf8_lossy(&out.stderr)
        );
    }
}
