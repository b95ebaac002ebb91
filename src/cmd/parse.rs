//! Parsers of command-line values shared by the subcommands (clap `value_parser`s): each
//! error names the value and what was expected.

use glam::{DVec3, Vec3};

/// `X,Y,Z`: three finite numbers.
pub fn vec3(s: &str) -> Result<Vec3, String> {
    let [x, y, z] = numbers::<3>(s)?;
    let v = DVec3::new(x, y, z).as_vec3();
    match v.is_finite() {
        true => Ok(v),
        false => Err(format!(
            "{s:?}: coordinates must be finite in single precision"
        )),
    }
}

/// `N` comma-separated values of type `T`, each error naming the value.
pub fn list<T: std::str::FromStr, const N: usize>(s: &str, what: &str) -> Result<[T; N], String>
where
    T::Err: std::fmt::Display,
{
    let v: Vec<T> = s
        .split(',')
        .map(|p| {
            p.trim()
                .parse::<T>()
                .map_err(|e| format!("{p:?} in {s:?}: {e}"))
        })
        .collect::<Result<_, _>>()?;
    let n = v.len();
    v.try_into()
        .map_err(|_| format!("{s:?}: {n} values, expected {what}"))
}

/// `N` comma-separated finite numbers.
fn numbers<const N: usize>(s: &str) -> Result<[f64; N], String> {
    let v: [f64; N] = list(s, &format!("{N} numbers"))?;
    if v.iter().any(|x| !x.is_finite()) {
        return Err(format!("{s:?}: values must be finite"));
    }
    Ok(v)
}

/// `X0,Y0,Z0,X1,Y1,Z1`: a box's lower and upper corners, each coordinate of the first
/// below the second's.
pub fn aabb(s: &str) -> Result<[DVec3; 2], String> {
    let [a, b, c, d, e, f] = numbers::<6>(s)?;
    let (lo, hi) = (DVec3::new(a, b, c), DVec3::new(d, e, f));
    if !lo.cmplt(hi).all() {
        return Err(format!("{s:?}: each of X0,Y0,Z0 must be below X1,Y1,Z1"));
    }
    Ok([lo, hi])
}

/// `NX,NY,NZ`: a grid's cells along each axis, each at least 1.
pub fn grid(s: &str) -> Result<[u32; 3], String> {
    let g = numbers::<3>(s)?;
    if g.iter()
        .any(|&n| n < 1.0 || n.fract() != 0.0 || n > f64::from(u32::MAX))
    {
        return Err(format!("{s:?}: cells must be whole numbers, at least 1"));
    }
    Ok(g.map(|n| n as u32))
}

/// `PA;PB;PC`: a screen rectangle's lower-left, lower-right and upper-left corners.
pub fn screen(s: &str) -> Result<[Vec3; 3], String> {
    let corners: Vec<Vec3> = s.split(';').map(vec3).collect::<Result<_, _>>()?;
    let [pa, pb, pc] = corners[..] else {
        return Err(format!("{s:?}: expected three corners PA;PB;PC"));
    };
    let (right, up) = (pb - pa, pc - pa);
    if right.cross(up).length() < 1e-9 {
        return Err(format!("{s:?}: the corners do not span a rectangle"));
    }
    if right.normalize().dot(up.normalize()).abs() > 1e-3 {
        return Err(format!("{s:?}: PA→PB and PA→PC are not perpendicular"));
    }
    Ok([pa, pb, pc])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_values_are_named() {
        assert_eq!(vec3("1, 2,3").unwrap(), Vec3::new(1.0, 2.0, 3.0));
        assert!(vec3("1,2").unwrap_err().contains("expected 3 numbers"));
        assert!(vec3("1,2,inf").unwrap_err().contains("finite"));
        assert!(vec3("1,2,1e39").unwrap_err().contains("finite"));
        assert!(vec3("1,x,3").unwrap_err().contains("\"x\""));
        assert!(screen("0,0,0;1,0,0;0,1,0").is_ok());
        assert!(
            screen("0,0,0;1,0,0;1,1,0")
                .unwrap_err()
                .contains("perpendicular")
        );
        assert!(
            screen("0,0,0;1,0,0;2,0,0")
                .unwrap_err()
                .contains("rectangle")
        );
        assert_eq!(aabb("0,0,0,1,2,3").unwrap()[1], DVec3::new(1.0, 2.0, 3.0));
        assert!(
            aabb("0,0,0,1,2")
                .unwrap_err()
                .contains("5 values, expected 6 numbers")
        );
        assert!(aabb("0,0,0,1,-2,3").unwrap_err().contains("below"));
        assert_eq!(grid("4,5,6").unwrap(), [4, 5, 6]);
        assert!(grid("4,0,6").unwrap_err().contains("at least 1"));
        assert!(grid("4,1.5,6").unwrap_err().contains("whole"));
    }
}
