//! "Did you mean": the closest known name to a misspelt one, by edit distance, so that an
//! unknown name or keyword comes with the likely fix.

/// Edit distance between two names (by characters), counting a swap of two neighbouring
/// characters as one edit, the most common typing slip (`stpe` for `step`).
pub fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    let width = b.len() + 1;
    // d[i][j]: distance between the first i characters of a and the first j of b.
    let mut d = vec![0usize; (a.len() + 1) * width];
    for j in 0..=b.len() {
        d[j] = j;
    }
    for i in 1..=a.len() {
        d[i * width] = i;
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            let mut best = (d[(i - 1) * width + j] + 1)
                .min(d[i * width + j - 1] + 1)
                .min(d[(i - 1) * width + j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                best = best.min(d[(i - 2) * width + j - 2] + 1);
            }
            d[i * width + j] = best;
        }
    }
    d[a.len() * width + b.len()]
}

/// The closest candidate within a distance that scales with the name's length (a third of it,
/// at least one edit), ties broken by the first candidate in order.
pub fn closest<'a>(name: &str, candidates: impl Iterator<Item = &'a str>) -> Option<&'a str> {
    let limit = (name.chars().count() / 3).max(1);
    let lower = name.to_lowercase();
    let mut best: Option<(usize, &str)> = None;
    for candidate in candidates {
        if candidate == name {
            continue;
        }
        let distance = if candidate.to_lowercase() == lower {
            0
        } else {
            edit_distance(name, candidate)
        };
        if distance <= limit && best.is_none_or(|(d, _)| distance < d) {
            best = Some((distance, candidate));
        }
    }
    best.map(|(_, c)| c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_close_names() {
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("stpe", "step"), 1);
        assert_eq!(
            closest("stpe", ["step", "frames"].into_iter()),
            Some("step")
        );
        assert_eq!(
            closest("idenity", ["identity", "ident", "grad"].into_iter()),
            Some("identity")
        );
        assert_eq!(closest("Grad", ["grad", "div"].into_iter()), Some("grad"));
        assert_eq!(closest("xyz", ["grad", "div"].into_iter()), None);
    }
}
