"""Callers, scopes and wildcards; signed, expiring scope tokens (JWT, HS256) on a fake clock."""

import time

import jwt
import pytest

from tools import Caller, InvalidToken, TokenAuthority
from tools.auth import SECRET_ENV

from .conftest import SECRET, FakeClock

PAST = 1_600_000_000.0  # a fake wall clock behind the real one (see test_a_clock_ahead_of_the_wall_clock)


# callers and scopes -----------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("held", "needed", "allowed"),
    [
        ({"flight:command"}, "flight:command", True),
        ({"flight:*"}, "flight:command", True),
        ({"flight:*"}, "flight:command:arm", True),
        ({"*"}, "anything:at_all", True),
        ({"*"}, "admin", True),
        ({"flight:read"}, "flight:command", False),
        ({"weather:*"}, "flight:command", False),
        ({"flight"}, "flight:command", False),
        ({"admin:*"}, "admin", False),  # a scope without a namespace is matched exactly
        ({"flight:comm*"}, "flight:command", False),  # only a whole namespace is a wildcard
        (set(), "flight:command", False),
    ],
)
def test_caller_allows(held: set[str], needed: str, allowed: bool) -> None:
    assert Caller(id="c", scopes=frozenset(held)).allows(needed) is allowed


def test_caller_missing_lists_what_is_lacking_in_order() -> None:
    caller = Caller(id="c", scopes=frozenset({"flight:*", "camera:read"}))
    assert caller.missing(["weather:read", "flight:arm", "camera:write", "camera:read"]) == [
        "weather:read",
        "camera:write",
    ]
    assert caller.missing([]) == []


# tokens -----------------------------------------------------------------------------------------------------------
def test_issue_and_verify() -> None:
    authority = TokenAuthority(SECRET)
    caller = authority.verify(authority.issue("mission:patrol", ["flight:*", "camera:read", "flight:*"], ttl_s=60))
    assert caller == Caller(id="mission:patrol", scopes=frozenset({"flight:*", "camera:read"}))
    assert caller.allows("flight:command") and not caller.allows("weather:read")


def test_token_claims() -> None:
    wall = FakeClock(PAST)
    token = TokenAuthority(SECRET, clock=wall).issue("drone-7", ["b:x", "a:y"], ttl_s=120)
    claims = jwt.decode(token, SECRET, algorithms=["HS256"], options={"verify_exp": False})
    assert claims["sub"] == "drone-7" and claims["scope"] == "a:y b:x" and claims["iss"] == "agentic-uavs"
    assert claims["iat"] == int(PAST) and claims["exp"] == PAST + 120 and len(claims["jti"]) == 32
    assert jwt.get_unverified_header(token)["alg"] == "HS256"


def test_a_bytes_secret() -> None:
    authority = TokenAuthority(SECRET.encode())
    assert authority.verify(authority.issue("x", ["a:b"])).id == "x"
    assert TokenAuthority(SECRET).verify(authority.issue("x", [])).id == "x"  # the same key as the text secret


def test_a_short_secret_is_refused() -> None:
    with pytest.raises(ValueError, match="at least 32 bytes"):
        TokenAuthority("x" * 31)


def test_ttl_must_be_positive() -> None:
    with pytest.raises(ValueError, match="ttl_s must be positive"):
        TokenAuthority(SECRET).issue("x", [], ttl_s=0)


def test_expiry_on_a_fake_clock() -> None:
    wall = FakeClock(PAST)
    authority = TokenAuthority(SECRET, clock=wall)
    token = authority.issue("x", ["a:b"], ttl_s=30)
    wall.advance(29.999)
    assert authority.verify(token).id == "x"
    wall.advance(0.001)
    with pytest.raises(InvalidToken, match="invalid token: it has expired"):
        authority.verify(token)


def test_a_clock_ahead_of_the_wall_clock() -> None:
    """Tokens issued and verified on the authority's own clock are valid on it, wherever that clock stands."""
    wall = FakeClock(time.time() + 86_400)
    authority = TokenAuthority(SECRET, clock=wall)
    assert authority.verify(authority.issue("x", ["a:b"], ttl_s=60)).id == "x"


def test_forged_garbage_and_foreign_tokens() -> None:
    authority = TokenAuthority(SECRET)
    forged = TokenAuthority("f" * 32).issue("mallory", ["*"])
    with pytest.raises(InvalidToken, match="Signature verification failed"):
        authority.verify(forged)
    with pytest.raises(InvalidToken, match="invalid token"):
        authority.verify("not.a.jwt")
    with pytest.raises(InvalidToken, match="Invalid issuer"):
        authority.verify(TokenAuthority(SECRET, issuer="someone-else").issue("x", ["*"]))


def test_a_tampered_payload_is_refused() -> None:
    authority = TokenAuthority(SECRET)
    header, _, signature = authority.issue("guest", []).split(".")
    claims = {"sub": "guest", "scope": "*", "iss": "agentic-uavs", "exp": time.time() + 60}
    _, payload, _ = jwt.encode(claims, "x" * 32, algorithm="HS256").split(".")
    with pytest.raises(InvalidToken, match="Signature verification failed"):
        authority.verify(f"{header}.{payload}.{signature}")


def test_an_unsigned_token_is_refused() -> None:
    claims = {"sub": "x", "scope": "*", "iss": "agentic-uavs", "exp": time.time() + 60}
    token = jwt.encode(claims, None, algorithm="none")  # type: ignore[arg-type]
    with pytest.raises(InvalidToken, match="invalid token"):
        TokenAuthority(SECRET).verify(token)


@pytest.mark.parametrize(
    ("claims", "message"),
    [
        ({"sub": "x", "iss": "agentic-uavs"}, 'Token is missing the "exp" claim'),
        ({"scope": "*", "iss": "agentic-uavs", "exp": 4e9}, 'Token is missing the "sub" claim'),
        ({"sub": "x", "scope": "*", "exp": 4e9}, 'Token is missing the "iss" claim'),
        ({"sub": "x", "scope": ["a:b"], "iss": "agentic-uavs", "exp": 4e9}, "'sub' and 'scope' must be strings"),
    ],
)
def test_tokens_with_missing_or_bad_claims(claims: dict[str, object], message: str) -> None:
    token = jwt.encode(claims, SECRET, algorithm="HS256")
    with pytest.raises(InvalidToken, match=message):
        TokenAuthority(SECRET).verify(token)


def test_a_token_without_scopes_names_a_caller_with_none() -> None:
    token = jwt.encode({"sub": "x", "iss": "agentic-uavs", "exp": 4e9}, SECRET, algorithm="HS256")
    assert TokenAuthority(SECRET).verify(token) == Caller(id="x")


def test_from_env(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(SECRET_ENV, raising=False)
    assert TokenAuthority.from_env() is None
    monkeypatch.setenv(SECRET_ENV, SECRET)
    authority = TokenAuthority.from_env()
    assert authority is not None
    assert TokenAuthority(SECRET).verify(authority.issue("x", ["a:b"])).id == "x"
    monkeypatch.setenv("OTHER_SECRET", "short")
    with pytest.raises(ValueError, match="at least 32 bytes"):
        TokenAuthority.from_env("OTHER_SECRET")
