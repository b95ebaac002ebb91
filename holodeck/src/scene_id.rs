//! Which scene a holodeck's samples were traced in: the scene file's name and the
//! fingerprint of everything its light depends on (`holocave_scene::Scene::fingerprint`:
//! geometry, materials, lights, daylight), so a worker tracing the same file under
//! another daylight is told apart. Files written before they carried a fingerprint record
//! the name alone, and are matched by name.

/// The identity a holodeck file records and its workers present.
pub fn scene_id(file_name: &str, fingerprint: u64) -> String {
    format!("{file_name} #{fingerprint:016x}")
}

/// Whether a worker presenting `offered` traces the scene recorded as `recorded`.
pub fn same_scene(recorded: &str, offered: &str) -> bool {
    match (split(recorded), split(offered)) {
        ((_, Some(_)), _) => recorded == offered,
        ((name, None), (offered_name, _)) => name == offered_name,
    }
}

/// The fingerprint an identity records (none in a name alone).
pub fn fingerprint_of(id: &str) -> Option<u64> {
    split(id).1.and_then(|fp| u64::from_str_radix(fp, 16).ok())
}

/// An identity's file name and fingerprint (none in a name alone).
fn split(id: &str) -> (&str, Option<&str>) {
    match id.rsplit_once(" #") {
        Some((name, fp)) if fp.len() == 16 && fp.bytes().all(|b| b.is_ascii_hexdigit()) => {
            (name, Some(fp))
        }
        _ => (id, None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fingerprint_tells_scenes_of_one_file_apart_and_old_files_match_by_name() {
        let a = scene_id("room.gltf", 0x1234);
        assert_eq!(a, "room.gltf #0000000000001234");
        assert!(same_scene(&a, &a));
        assert!(!same_scene(&a, &scene_id("room.gltf", 0x1235)));
        assert!(!same_scene(&a, &scene_id("hall.gltf", 0x1234)));
        assert!(same_scene("room.gltf", &a));
        assert!(!same_scene("hall.gltf", &a));
        // A name with the separator in it.
        let odd = scene_id("a #b.gltf", 7);
        assert!(same_scene("a #b.gltf", &odd) && same_scene(&odd, &odd));
    }
}
