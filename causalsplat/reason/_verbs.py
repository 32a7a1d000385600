"""What a need asks an object to do: its verbs, matched to what the knowledge table says
objects afford.

A sentence embedding weighs every word of a need alike, so the nouns it merely mentions
pull it towards the objects they name. What the need asks of the object is its verb:
somewhere to *lie down*, something to *cook* with, somewhere to *put* a thing *on*. The
grounding stage uses it to tell when nothing in a room does what is asked (stools come
close to "I want to lie down" by meaning, but only couches and beds afford it; see
``ground.VERB_SHARE``). :func:`need_verbs` finds the verb of a need's purpose clause
(the first word WordNet knows as a verb, not a light verb, not after a determiner or a
form of "be") and :func:`verb_fit` how well a category's facts afford it: its ``affords`` and
``for`` phrases open with the verb, a WordNet synonym of it or a verb it is a kind of
("chop" is a kind of "cut"), with the need's particle ("put ... on") when it has one. The
need's other words (its objects) count only with the verb: a pot affords cooking and
holds pasta.

>>> from causalsplat.reason.lexicon import load_lexicon
>>> from causalsplat.reason.knowledge import load_knowledge
>>> lex, table = load_lexicon(), load_knowledge()
>>> need = need_verbs(("i", "want", "to", "cook", "pasta"), lex)
>>> need.verbs, need.objects
(('cook',), ('pasta',))
>>> [round(verb_fit(need, table.get(c), lex), 2) for c in ("pot", "stove", "plate")]
[1.0, 0.75, 0.0]
>>> on = need_verbs(("something", "to", "put", "my", "coffee", "on"), lex)
>>> [round(verb_fit(on, table.get(c), lex), 2) for c in ("tray", "cup")]
[0.75, 0.0]

"Which thing needs watering?" asks for what undergoes the verb, not what helps do it
(:func:`patient_verb`): only what people water (its ``affords``) can be the answer.

>>> patient_verb(("which", "thing", "needs", "watering", "?"), lex)
'water'
>>> patient_verb(("what", "should", "be", "cleaned", "?"), lex)
'clean'
>>> patient_verb(("i", "need", "to", "water", "the", "plants"), lex) is None
True
>>> patient_verb(("store", "clothes", "that", "need", "washing"), lex) is None
True
"""

from __future__ import annotations

from dataclasses import dataclass

from causalsplat.reason._grammar import ACTION_STOPWORDS, DETERMINERS, PARTICLES, POSSESSIVES
from causalsplat.reason.knowledge import ObjectFacts
from causalsplat.reason.lexicon import Lexicon

#: Verbs too general to tell one object's use from another's ("make the bed", "have a
#: look", "need watering"): they neither make a need's verb nor match one.
LIGHT_VERBS = frozenset({
    "be", "have", "make", "do", "get", "take", "give", "go", "come", "use", "let", "keep",
    "need", "want", "like", "try", "start", "stop", "help", "feel", "look", "seem", "see",
    "say", "tell", "know", "think", "find", "move", "change", "turn", "hold", "bring",
})  # fmt: skip
#: Words after which a word is a noun ("the baby", "my hands").
NOUN_MARKERS = DETERMINERS
#: Words after which a participle says how someone is, not what they want to do ("I am
#: tired", "I feel so bored").
STATE_MARKERS = frozenset({"am", "is", "are", "was", "were", "be", "been", "'m", "'re", "'s",
                           "feel", "feeling", "so", "too", "very", "really"})  # fmt: skip
_NOT_A_VERB_AFTER = NOUN_MARKERS | STATE_MARKERS
#: A synonym of the need's verb counts this much, a verb the one is a kind of this much.
SYNONYM = 0.8
KIND_OF = 0.5
#: What the particle ("on" of "put ... on") leaves of a match when the phrase has another.
OTHER_PARTICLE = 0.5
#: The share of a match that the need's objects decide: a category that affords the verb
#: scores ``1 - OBJECT_SHARE`` of it, one that also holds or names what it acts on, all.
OBJECT_SHARE = 0.25


@dataclass(frozen=True, slots=True)
class NeedVerbs:
    """A need's verbs (base forms), its trailing particle and the nouns it acts on."""

    verbs: tuple[str, ...]
    particle: str | None
    objects: tuple[str, ...]


def need_verbs(tokens: tuple[str, ...], lexicon: Lexicon) -> NeedVerbs:
    """The verb, particle and objects of a need's purpose clause (its tokens, states
    already read as what they call for): the first word with a verb sense that is not
    light, not a stop word, not after a determiner ("the baby play": "baby" is a noun
    there) nor after a form of "be" ("I am tired" states how one is); the nouns after it
    are what it acts on; a trailing particle is kept."""
    verb: str | None = None
    objects: list[str] = []
    words = [t for t in tokens if t.isalpha() or "'" in t]
    prev = ""
    for w in words:
        if verb is None:
            if w not in ACTION_STOPWORDS and prev not in _NOT_A_VERB_AFTER:
                base = lexicon.lemma(w, "v")
                if base not in LIGHT_VERBS and lexicon.verb_senses(base):
                    verb = base
        elif w not in ACTION_STOPWORDS and w not in PARTICLES and w not in DETERMINERS:
            objects.append(lexicon.lemma(w, "n"))
        prev = w
    particle = words[-1] if words and words[-1] in PARTICLES else None
    return NeedVerbs(() if verb is None else (verb,), particle, tuple(dict.fromkeys(objects)))


#: Forms of "need" and "want" that, before a gerund, make its subject what the gerund is
#: done to ("the plant needs watering": the plant is watered).
_NEED_FORMS = frozenset({"need", "needs", "needed", "want", "wants", "wanted"})
#: Words before "be" + participle that make the participle's verb a request ("what should
#: be cleaned", "what has to be fixed", "what needs to be watered").
_MODAL_BEFORE_BE = frozenset({"should", "must", "can", "could", "needs", "need", "ought",
                              "to", "has", "have"})  # fmt: skip

#: Pronouns opening a relative clause after a noun.
_RELATIVE = frozenset({"that", "which", "who"})


def patient_verb(tokens: tuple[str, ...], lexicon: Lexicon) -> str | None:
    """The verb of a need whose answer undergoes it, or ``None``: "need(s) + gerund"
    ("which thing needs watering?") and a modal passive ("what should be cleaned?", "what
    needs to be watered?"). "I need to water the plants" is the speaker's own act: no
    patient reading (the plants are named; the answer is what helps)."""
    for i in range(len(tokens) - 1):
        word, nxt = tokens[i], tokens[i + 1]
        if i >= 2 and tokens[i - 1] in _RELATIVE and tokens[i - 2].isalpha():
            continue  # "clothes that need washing": said of what the need acts on
        if word in _NEED_FORMS and nxt.endswith("ing"):
            base = lexicon.lemma(nxt, "v")
            if base != nxt and base not in LIGHT_VERBS and lexicon.verb_senses(base):
                return base
        if word == "be" and i > 0 and tokens[i - 1] in _MODAL_BEFORE_BE and nxt.endswith("ed"):
            base = lexicon.lemma(nxt, "v")
            if base != nxt and base not in LIGHT_VERBS and lexicon.verb_senses(base):
                return base
    return None


def affords_verb(
    verb: str,
    facts: ObjectFacts | None,
    lexicon: Lexicon,
    particles: frozenset[str] | None = None,
) -> bool:
    """Whether people do ``verb`` (or a synonym of it) to the object: an ``affords`` phrase
    opens with it. With ``particles`` (those the need says), a phrase with other particles
    only is another act: shoes are put on, and "put my shoes in" puts them somewhere; a
    need without particles says nothing of them ("drink a cup of coffee" drinks from it).

    >>> from causalsplat.reason.lexicon import load_lexicon
    >>> from causalsplat.reason.knowledge import load_knowledge
    >>> lex, shoe = load_lexicon(), load_knowledge().get("shoe")
    >>> affords_verb("put", shoe, lex), affords_verb("put", shoe, lex, frozenset({"on"}))
    (True, True)
    >>> affords_verb("put", shoe, lex, frozenset({"in"}))
    False
    >>> affords_verb("put", shoe, lex, frozenset())
    True
    """
    if facts is None:
        return False
    return any(
        _relatedness(verb, head, lexicon) >= SYNONYM
        and not (particles and _other_particles(words, particles))
        for head, words in _headed(facts.affords, lexicon)
    )


def _other_particles(words: list[str], said: frozenset[str]) -> bool:
    """Whether a phrase (its words, verb first) carries particles and none the need says."""
    tail = PARTICLES.intersection(words[1:])
    return bool(tail) and not tail & said


#: Objects that stand for anything ("store items"): they agree with every object.
_ANY_OBJECT = frozenset({"item", "items", "thing", "things", "stuff", "object", "objects",
                         "belongings"})  # fmt: skip

#: Possessives before an object ("your hands", "one's teeth").
_POSSESSIVES = POSSESSIVES | {"one's"}
#: How many hypernym steps apart two objects may be and still be one kind ("meal" is a
#: kind of "food" two steps up).
KIND_DEPTH = 4


def phrase_agrees(need: NeedVerbs, phrase: str, lexicon: Lexicon) -> bool | None:
    """Whether a verb phrase ("dry hands", "store food", "keeping food cold") does what the
    need asks: ``False`` when its verb is another ("wash my hands" is no "dry hands") or
    acts on another kind of thing ("store my dishes" is no "store food"; "store items"
    takes anything); ``True`` when the verbs are one, synonyms or one a kind of the other
    and the objects (when both name one) are one kind; ``None`` when the phrase opens with
    no verb or the need has none (it says nothing either way)."""
    words = phrase.split()
    if not words or not need.verbs:
        return None
    head = lexicon.lemma(words[0], "v")
    if head in LIGHT_VERBS or not lexicon.verb_senses(head):
        return None
    if _verb_relatedness(need, head, lexicon) <= 0.0:
        return False
    objects = [
        lexicon.lemma(w, "n")
        for w in words[1:]
        if w.isalpha()
        and w not in ACTION_STOPWORDS
        and w not in DETERMINERS
        and w not in _POSSESSIVES
        and lexicon.noun_senses(lexicon.lemma(w, "n"))
    ]
    wanted = [o for o in need.objects if lexicon.noun_senses(o)]
    if not objects or not wanted or any(o in _ANY_OBJECT for o in (*objects, *wanted)):
        return True
    return any(_one_kind(o, w, lexicon) for o in objects for w in wanted)


def _one_kind(a: str, b: str, lexicon: Lexicon) -> bool:
    """``a`` and ``b`` in their first senses are one kind: the same synset, or one a
    hypernym of the other within :data:`KIND_DEPTH` steps."""
    if a == b:
        return True
    sa, sb = lexicon.noun_senses(a)[:1], lexicon.noun_senses(b)[:1]
    if not sa or not sb:
        return False
    first_a, first_b = sa[0], sb[0]
    return first_b in lexicon.hypernym_closure(first_a, KIND_DEPTH) or (
        first_a in lexicon.hypernym_closure(first_b, KIND_DEPTH)
    )


def _relatedness(a: str, b: str, lexicon: Lexicon) -> float:
    """1 for one verb, :data:`SYNONYM` for verbs sharing one of their first two senses,
    :data:`KIND_OF` when one's first two senses have the other as a direct hypernym."""
    if a == b:
        return 1.0
    if a in LIGHT_VERBS or b in LIGHT_VERBS:
        return 0.0
    best = 0.0
    for x, y in ((a, b), (b, a)):
        for k, s in enumerate(lexicon.verb_senses(x)[:2]):
            if y in lexicon.verb_lemmas(s):
                return SYNONYM
            if k == 0 and any(y in lexicon.verb_lemmas(h) for h in lexicon.verb_hypernyms(s)):
                best = KIND_OF
    return best


def _headed(phrases: tuple[str, ...], lexicon: Lexicon) -> list[tuple[str, list[str]]]:
    """Each non-empty phrase's head (its first word as a verb's base form) and words."""
    return [(lexicon.lemma(words[0], "v"), words) for words in map(str.split, phrases) if words]


def _verb_relatedness(need: NeedVerbs, head: str, lexicon: Lexicon) -> float:
    """How near ``head`` is to the closest of the need's verbs (:func:`_relatedness`)."""
    return max(_relatedness(v, head, lexicon) for v in need.verbs)


def verb_fit(need: NeedVerbs, facts: ObjectFacts | None, lexicon: Lexicon) -> float:
    """How well a category's facts afford the need's verbs, in ``[0, 1]`` (module
    docstring); 0 without facts or verbs."""
    if facts is None or not need.verbs:
        return 0.0
    best = 0.0
    for head, words in _headed((*facts.affords, *facts.uses), lexicon):
        rel = _verb_relatedness(need, head, lexicon)
        if rel <= 0.0:
            continue
        if need.particle is not None and _other_particles(words, frozenset({need.particle})):
            rel *= OTHER_PARTICLE
        best = max(best, rel)
    if best <= 0.0:
        return 0.0
    if not need.objects:
        return best
    named = {lexicon.lemma(w, "n") for p in (*facts.holds, *facts.uses, *facts.affords)
             for w in p.split()}  # fmt: skip
    acts_on = any(o in named for o in need.objects)
    return best * ((1.0 - OBJECT_SHARE) + (OBJECT_SHARE if acts_on else 0.0))


def does_to(need: NeedVerbs, facts: ObjectFacts | None, lexicon: Lexicon) -> bool:
    """Whether one phrase of a category's facts does the need's verb to what the need acts
    on ("hanging towels" of a towel rack, for "hang my towels"): the phrase opens with the
    verb (or a synonym) and names one of the need's objects.

    >>> from causalsplat.reason.lexicon import load_lexicon
    >>> from causalsplat.reason.knowledge import load_knowledge
    >>> lex, table = load_lexicon(), load_knowledge()
    >>> need = need_verbs(("i", "want", "to", "wash", "my", "clothes"), lex)
    >>> does_to(need, table.get("washing machine"), lex), does_to(need, table.get("sink"), lex)
    (True, False)
    """
    if facts is None or not need.verbs or not need.objects:
        return False
    return any(
        _verb_relatedness(need, head, lexicon) >= SYNONYM
        and any(lexicon.lemma(w, "n") in need.objects for w in words[1:])
        for head, words in _headed((*facts.affords, *facts.uses), lexicon)
    )
